"""x_click.py X Y DELAY_S DONE_FILE: after DELAY_S seconds, left clicks at
screen point (X, Y) sent through the X server (XTest, libXtst of Debian's
libxtst6), as a user's mouse would: one every 0.5 s (a user clicks again when
the first click finds the button still grey, e.g. before the build reports
progress) until the caller stops this process, at most 60; the time of the
first click goes to DONE_FILE. Started by
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
for click in range(60):
    xtest.XTestFakeMotionEvent(display, -1, x, y, 0)
    xlib.XFlush(display)
    time.sleep(0.05)
    if click == 0:
        # The time the first click is sent, written before it: once it lands
        # the update may return and the test stop this process at once (it did,
        # between the release and a write after it: the test read no time).
        with open(done, "w") as f:
            f.write("%f\n" % time.time())
    xtest.XTestFakeButtonEvent(display, 1, True, 0)
    xlib.XFlush(display)
    time.sleep(0.05)
    xtest.XTestFakeButtonEvent(display, 1, False, 0)
    xlib.XFlush(display)
    time.sleep(0.5)
xlib.XCloseDisplay(display)
