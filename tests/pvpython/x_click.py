"""x_click.py X Y DELAY_S DONE_FILE: after DELAY_S seconds, a left click at
screen point (X, Y) sent through the X server (XTest, libXtst of Debian's
libxtst6), as a user's mouse would; then writes DONE_FILE. Started by
test_gui_abort.py as a separate process, since the GUI's own thread is busy
with the build it is meant to stop."""
import ctypes
import sys
import time

x, y, delay, done = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
time.sleep(delay)
xlib = ctypes.CDLL("libX11.so.6")
xtest = ctypes.CDLL("libXtst.so.6")
xlib.XOpenDisplay.restype = ctypes.c_void_p
xlib.XOpenDisplay.argtypes = [ctypes.c_char_p]
xlib.XFlush.argtypes = [ctypes.c_void_p]
xlib.XCloseDisplay.argtypes = [ctypes.c_void_p]
xtest.XTestFakeMotionEvent.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_ulong]
xtest.XTestFakeButtonEvent.argtypes = [ctypes.c_void_p, ctypes.c_uint, ctypes.c_int, ctypes.c_ulong]
display = xlib.XOpenDisplay(None)
if not display:
    sys.exit("x_click.py: cannot open the X display")
xtest.XTestFakeMotionEvent(display, -1, x, y, 0)
xlib.XFlush(display)
time.sleep(0.2)
xtest.XTestFakeButtonEvent(display, 1, True, 0)
xlib.XFlush(display)
time.sleep(0.05)
xtest.XTestFakeButtonEvent(display, 1, False, 0)
xlib.XFlush(display)
xlib.XCloseDisplay(display)
with open(done, "w") as f:
    f.write("%f\n" % time.time())
