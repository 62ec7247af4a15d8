#!/usr/bin/env bash
# Installs the Debian packages of scripts/debian-packages.txt that are missing.
#
# Idempotent and fast when nothing is missing: one dpkg-query, no apt-get at
# all (no `apt-get update`, which takes long and needs the network).
#   bash scripts/install-deps.sh           install what is missing
#   bash scripts/install-deps.sh --check   list what is missing; exit 1 if anything is
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
list="$here/debian-packages.txt"

# The list without comments and blank lines.
mapfile -t wanted < <(sed -e 's/#.*//' -e 's/[[:space:]]//g' -e '/^$/d' "$list")

# Installed ones among them: status "ii". dpkg-query complains on stderr about
# names it has never seen; those are simply missing.
declare -A installed=()
while read -r pkg status; do
  [[ $status == ii ]] && installed[$pkg]=1
done < <(dpkg-query -W -f='${Package} ${db:Status-Abbrev}\n' "${wanted[@]}" 2>/dev/null || true)
missing=()
for pkg in "${wanted[@]}"; do
  [[ -n ${installed[$pkg]:-} ]] || missing+=("$pkg")
done

if [[ ${1:-} == --check ]]; then
  if ((${#missing[@]})); then
    printf 'missing: %s\n' "${missing[*]}"
    exit 1
  fi
  echo "all ${#wanted[@]} packages are installed"
  exit 0
fi

if ((${#missing[@]} == 0)); then
  echo "install-deps: all ${#wanted[@]} packages are installed"
  exit 0
fi

# Root runs apt-get directly; anyone else needs sudo.
as_root=()
if [[ $(id -u) -ne 0 ]]; then
  if ! command -v sudo >/dev/null; then
    echo "install-deps: missing packages: ${missing[*]}" >&2
    echo "install-deps: run this script as root, or install sudo" >&2
    exit 1
  fi
  as_root=(sudo)
fi

echo "install-deps: installing ${#missing[@]} package(s): ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${as_root[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -q
"${as_root[@]}" env DEBIAN_FRONTEND=noninteractive \
  apt-get install -y -q --no-install-recommends "${missing[@]}"
