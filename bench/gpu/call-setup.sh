# Sourced by the device-call scripts (bench/gpu/*-s18/, *-s19/) from the
# repository root, with carry [".devdeps"]: the device machine's environment
# for the binaries carried in .devcarry/NAME.tar.xz (untracked), unpacked to
# /tmp; T0 starts the call's clock.
#   . bench/gpu/call-setup.sh NAME
set -u
ROOT=$(pwd)
export LD_LIBRARY_PATH=$ROOT/.devdeps/lib/x86_64-linux-gnu:/usr/local/cuda/lib64 HDT_MESHES_DIR=$ROOT/.devdeps/meshes
export PATH=/usr/local/cuda/bin:$PATH
T0=$SECONDS
tar xJf ".devcarry/$1.tar.xz" -C /tmp || { echo "unpack failed"; exit 1; }
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader
date -u
