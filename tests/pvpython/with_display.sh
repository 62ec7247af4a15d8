#!/bin/sh
# with_display.sh CMD [ARGS...]: runs CMD with an X display, the current one
# or else a private Xvfb server (xvfb-run -a, Debian package xvfb). Debian's
# ParaView renders only through X (no EGL or OSMesa build). -noreset: ParaView
# opens and closes a window to probe OpenGL before it renders, and a server
# that resets when its last client leaves refuses connections meanwhile.
if [ -n "${DISPLAY:-}" ]; then
  exec "$@"
fi
if ! command -v xvfb-run >/dev/null; then
  echo "with_display.sh: no DISPLAY and no xvfb-run (install xvfb)" >&2
  exit 1
fi
exec xvfb-run -a --server-args="-screen 0 1280x1024x24 -noreset" "$@"
