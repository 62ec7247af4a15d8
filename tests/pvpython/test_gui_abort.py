"""GUI test of the Abort button, run inside the ParaView application:
  paraview --script=test_gui_abort.py --exit   (ctest sets HDT_PLUGIN, HDT_GUI_HELPER, HDT_X_CLICK, HDT_TMP)
Starts an HDT Voxelizer build that takes several seconds (a sphere at 4096^3,
CPU backend: about 7 s on one core of the development machine), and a left
click on the status bar's Abort button from 0.5 s later (again every 0.5 s, as a user would, until the update returns), sent through the X server
(XTest) by another process (x_click.py) at the place the GUI helper
(gui_test_helper.cxx) reads from the button: a user's click. Before the
build a warning pops ParaView's Output Messages window up over the button, as
any warning does; the plugin must move it clear of the button (HDT_TRACE=1
logs every mouse press and release the GUI sees). Checks that the
click came during the update, that the update then returned with an empty output and no error, that showing and rendering the
aborted filter does not start the build again, and that the next build (a
changed Resolution) runs to the end: the abort flag was cleared. Before
that, reads the Properties panel's Resolution list: the valid values for the
default Root Grid and Leaf Grid Size (256 .. 65536), and 32 .. 65536 once they
are 4 and 8. Prints "gui_abort: ok" when all of that held."""
import ctypes
import os
import subprocess
import sys
import time

from paraview.simple import *  # noqa: F401,F403
from vtkmodules.vtkCommonCore import vtkOutputWindow

plugin, clicker, tmp = os.environ["HDT_PLUGIN"], os.environ["HDT_GUI_HELPER"], os.environ["HDT_TMP"]
os.makedirs(tmp, exist_ok=True)
LoadPlugin(plugin, remote=False, ns=globals())
helper = ctypes.CDLL(clicker)

problems = []
if os.environ.get("HDT_TRACE"):
    helper.hdt_trace_mouse()
helper.hdt_panel_combo_items.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_int]


helper.hdt_widget_at.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_char_p, ctypes.c_int]


def widget_at(px, py):
    text = ctypes.create_string_buffer(256)
    helper.hdt_widget_at(px, py, text, len(text))
    return text.value.decode()


def panel_resolution_list():
    text = ctypes.create_string_buffer(4096)
    helper.hdt_panel_combo_items(b"Resolution", text, len(text))
    return [int(v) for v in text.value.decode().split(",") if v]
RESOLUTION = int(os.environ.get("HDT_ABORT_RESOLUTION", "4096"))
CLICK_S = 0.5

sphere = Sphere(ThetaResolution=64, PhiResolution=64)
sphere.UpdatePipeline()

# The Resolution list of the panel (before Apply, as a user sets them).
probe = HDTVoxelizer(Input=sphere)
SetActiveSource(probe)
default_list = panel_resolution_list()
probe.RootGridSize, probe.LeafGridSize = 4, 8
small_list = panel_resolution_list()
if default_list != [256 * 2 ** h for h in range(9)] or small_list != [32 * 2 ** h for h in range(12)]:
    problems.append("the panel's Resolution list: %s (R = L = 16), %s (R = 4, L = 8)" % (default_list, small_list))
Delete(probe)
vox = HDTVoxelizer(Input=sphere, Resolution=RESOLUTION, Backend="CPU")
executions = []
vox.GetClientSideObject().AddObserver("StartEvent", lambda *args: executions.append(time.time()))

# The click, through the X server at the button's place on the screen, from
# another process (this thread is busy with the build).
x, y = ctypes.c_int(), ctypes.c_int()
if helper.hdt_abort_button_center(ctypes.byref(x), ctypes.byref(y)) != 0:
    problems.append("no Abort button in the main window")

# A warning before the build, as a user meets one sooner or later: ParaView
# pops its Output Messages dock up over the bottom centre of the main window,
# over the Abort button (the cause of the lost clicks of this test's earlier,
# intermittent runs). The plugin must move it clear of the button.
vtkOutputWindow.GetInstance().DisplayWarningText("gui_abort: a warning before the build\n")
covering = widget_at(x.value, y.value)
if covering == "QToolButton(AbortButton)":
    problems.append("the test's warning did not cover the Abort button: the test does not check uncovering")
done = os.path.join(tmp, "clicked")
if os.path.exists(done):
    os.remove(done)
clicker = subprocess.Popen([sys.executable if os.path.basename(sys.executable).startswith("python") else "python3",
                            os.environ["HDT_X_CLICK"],
                            str(x.value), str(y.value), str(CLICK_S), done])
start = time.time()
vox.UpdatePipeline()
elapsed = time.time() - start
clicker.terminate()  # no more clicks once the update returned
clicker.wait()
# Clicks sent just before the clicker stopped are still on their way: let
# them reach the (now grey) button here, not the next build's.
helper.hdt_drain_input(500)
clicked_at = float(open(done).read()) - start if os.path.exists(done) else None
cells = vox.GetDataInformation().GetNumberOfCells()
surface_cells = vox.GetDataInformation(1).GetNumberOfCells()
if clicked_at is None or clicked_at > elapsed:
    problems.append("the click (sent at %s s) came after the update (%.1f s)" % (clicked_at, elapsed))
if cells or surface_cells:
    problems.append("the build ran to the end (%d cells, %d surface cells, %.1f s; under the click point: %s, before the build: %s)"
                    % (cells, surface_cells, elapsed, widget_at(x.value, y.value), covering))

# What Apply does next: show the outputs and render. An aborted output must not
# start the build again.
before = len(executions)
view = GetActiveViewOrCreate("RenderView")
Show(OutputPort(vox, 1), view)
Render(view)
if len(executions) != before:
    problems.append("showing the aborted filter ran it again")

# The next build of the filter runs to the end (the abort flag was cleared).
vox.Resolution = 256
vox.UpdatePipeline()
rebuilt = vox.GetDataInformation().GetNumberOfCells()
if rebuilt <= 0:
    problems.append("the build after the abort gave no cells")

if problems:
    print("gui_abort: FAILED: " + "; ".join(problems))
else:
    print("gui_abort: ok (Resolution list %d .. %d, then %d .. %d; aborted %.2f s after the start, clicked at %.1f s; next build %d cells)" % (default_list[0], default_list[-1], small_list[0], small_list[-1], elapsed, clicked_at, rebuilt))
