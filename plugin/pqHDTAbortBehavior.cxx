// The Abort button for HDT builds in the ParaView 5.11 GUI: see the header for
// why ParaView 5.11 needs it and what each step does.
#include "pqHDTAbortBehavior.h"

#include "pqApplicationCore.h"
#include "pqCoreUtilities.h"
#include "pqPipelineSource.h"
#include "pqProgressManager.h"
#include "pqServer.h"
#include "pqServerManagerModel.h"

#include "vtkAlgorithm.h"
#include "vtkCommand.h"
#include "vtkSMProxy.h"

#include <QApplication>
#include <QDockWidget>
#include <QEventLoop>
#include <QToolButton>
#include <QWidget>
#include <QWindow>
#include <QThread>

#include <cstring>

namespace
{
vtkAlgorithm* clientSideAlgorithm(pqPipelineSource* source)
{
  vtkSMProxy* proxy = source ? source->getProxy() : nullptr;
  // Null with a remote server: there the algorithm lives in pvserver.
  return proxy ? vtkAlgorithm::SafeDownCast(proxy->GetClientSideObject()) : nullptr;
}

pqProgressManager* progressManager()
{
  pqApplicationCore* core = pqApplicationCore::instance();
  return core ? core->getProgressManager() : nullptr;
}

// The status bar's Abort button (pqProgressWidget names it "AbortButton").
QToolButton* abortButton()
{
  QWidget* mainWindow = pqCoreUtilities::mainWidget();
  return mainWindow ? mainWindow->findChild<QToolButton*>(QStringLiteral("AbortButton")) : nullptr;
}
} // namespace

//-----------------------------------------------------------------------------
pqHDTAbortBehavior::pqHDTAbortBehavior(QObject* parent)
  : QObject(parent)
{
}

//-----------------------------------------------------------------------------
pqHDTAbortBehavior::~pqHDTAbortBehavior()
{
  this->shutdown();
}

//-----------------------------------------------------------------------------
bool pqHDTAbortBehavior::isHDTAlgorithm(vtkObject* object)
{
  // vtkHDTVoxelizer and its subclasses: the HDT algorithms that check
  // CheckAbort while they work. The reader and HDT To Image do not (one read,
  // one bounded copy); for them the button stays grey rather than promise.
  static const char prefix[] = "vtkHDTVoxelizer";
  return vtkAlgorithm::SafeDownCast(object) &&
    std::strncmp(object->GetClassName(), prefix, sizeof(prefix) - 1) == 0;
}

//-----------------------------------------------------------------------------
void pqHDTAbortBehavior::startup()
{
  pqApplicationCore* core = pqApplicationCore::instance();
  pqProgressManager* progress = progressManager();
  if (this->Started || !core || !progress)
  {
    return; // no GUI (pvpython, pvbatch): nothing to do
  }
  this->Started = true;
  pqServerManagerModel* model = core->getServerManagerModel();
  this->connect(model, &pqServerManagerModel::sourceAdded, this, &pqHDTAbortBehavior::watchSource);
  this->connect(
    model, &pqServerManagerModel::preSourceRemoved, this, &pqHDTAbortBehavior::unwatchSource);
  // Sources made before the plugin was loaded (Tools > Manage Plugins).
  for (pqPipelineSource* source : model->findItems<pqPipelineSource*>())
  {
    this->watchSource(source);
  }
  this->connect(progress, &pqProgressManager::progress, this, &pqHDTAbortBehavior::onProgress);
  this->connect(progress, &pqProgressManager::abort, this, &pqHDTAbortBehavior::onAbortClicked);
}

//-----------------------------------------------------------------------------
void pqHDTAbortBehavior::shutdown()
{
  if (!this->Started)
  {
    return;
  }
  this->Started = false;
  for (pqPipelineSource* source : this->Watches.keys())
  {
    this->unwatchSource(source);
  }
  if (pqApplicationCore* core = pqApplicationCore::instance())
  {
    core->getServerManagerModel()->disconnect(this);
    core->getProgressManager()->disconnect(this);
  }
}

//-----------------------------------------------------------------------------
void pqHDTAbortBehavior::watchSource(pqPipelineSource* source)
{
  vtkAlgorithm* algorithm = clientSideAlgorithm(source);
  if (!isHDTAlgorithm(algorithm) || this->Watches.contains(source))
  {
    return;
  }
  Watch& watch = this->Watches[source];
  watch.Algorithm = algorithm;
  watch.ProgressObserver = algorithm->AddObserver(
    vtkCommand::ProgressEvent, this, &pqHDTAbortBehavior::onAlgorithmProgress);
  watch.EndObserver =
    algorithm->AddObserver(vtkCommand::EndEvent, this, &pqHDTAbortBehavior::onAlgorithmEnd);
}

//-----------------------------------------------------------------------------
// Uses only what watchSource stored: the source may be half destroyed.
void pqHDTAbortBehavior::unwatchSource(pqPipelineSource* source)
{
  if (!this->Watches.contains(source))
  {
    return;
  }
  const Watch watch = this->Watches.take(source);
  if (vtkAlgorithm* algorithm = watch.Algorithm)
  {
    if (algorithm == this->Running)
    {
      this->Running = nullptr;
    }
    algorithm->RemoveObserver(watch.ProgressObserver);
    algorithm->RemoveObserver(watch.EndObserver);
  }
}

//-----------------------------------------------------------------------------
// Every progress report of a watched HDT algorithm (the voxelizer reports at
// least every 50 ms inside its long loops).
void pqHDTAbortBehavior::onAlgorithmProgress(vtkObject* caller, unsigned long, void*)
{
  if (QThread::currentThread() != this->thread())
  {
    return; // Qt only on its own thread
  }
  vtkAlgorithm* algorithm = vtkAlgorithm::SafeDownCast(caller);
  if (algorithm && algorithm != this->Running && algorithm != this->Aborted)
  {
    this->Running = algorithm;
    if (pqProgressManager* progress = progressManager())
    {
      this->letClicksReachTheButton(progress);
      progress->setEnableAbort(true);
    }
    uncoverAbortButton();
  }
}

//-----------------------------------------------------------------------------
// On any warning or error ParaView 5.11 pops its Output Messages dock up as a
// floating window over the bottom centre of the main window
// (ParaViewMainWindow::handleMessage), that is over the status bar: on a
// 1152-pixel wide window it covers the Abort button, and every click on the
// button then lands on that window instead (a warning before or during a
// build was enough for a whole build's clicks to be lost). Floating docks
// that overlap the button are moved up just clear of it; nothing else changes.
void pqHDTAbortBehavior::uncoverAbortButton()
{
  QToolButton* button = abortButton();
  if (!button || !button->isVisible())
  {
    return;
  }
  const QRect target(button->mapToGlobal(QPoint(0, 0)), button->size());
  for (QWidget* window : QApplication::topLevelWidgets())
  {
    auto* dock = qobject_cast<QDockWidget*>(window);
    if (!dock || !dock->isVisible() || !dock->isFloating())
    {
      continue;
    }
    const QRect frame = dock->frameGeometry();
    if (frame.intersects(target))
    {
      dock->move(frame.left(), frame.top() - (frame.bottom() - target.top() + 1));
    }
  }
}

//-----------------------------------------------------------------------------
// pqProgressManager's event filter lets a mouse press through only when its
// receiver is on the non-blockable list, and a click from the window system
// reaches the main window's QWindow before Qt hands it to the widget under
// the cursor: with the QWindow off the list, no real click ever reached the
// progress bar's button (a press sent straight to the button did). Listing
// the QWindow lets the press through to that dispatch, where the filter sees
// it again with the widget as receiver and still drops it for every widget
// but the progress bar and its button.
void pqHDTAbortBehavior::letClicksReachTheButton(pqProgressManager* progress)
{
  QWidget* mainWindow = pqCoreUtilities::mainWidget();
  QWindow* window = mainWindow ? mainWindow->windowHandle() : nullptr;
  if (window && !progress->nonBlockableObjects().contains(window))
  {
    progress->addNonBlockableObject(window);
  }
}

//-----------------------------------------------------------------------------
// pqProgressManager::progress, emitted at most every 0.1 s while an update
// runs. Only during an HDT build, and only in a builtin session (as ParaView
// 6.1 does), let Qt deliver the events that came in: the click on Abort.
void pqHDTAbortBehavior::onProgress(const QString&, int value)
{
  if (!this->Running || value <= 0)
  {
    return; // at 0 % ParaView's own timers are not ready for it (pqProgressManager.cxx)
  }
  pqApplicationCore* core = pqApplicationCore::instance();
  pqServer* server = core ? core->getActiveServer() : nullptr;
  if (server && server->isRemote())
  {
    return;
  }
  // A warning during the build may have popped a window over the button.
  uncoverAbortButton();
  // Input and paint events only: no timers, so nothing timer-driven (a view's
  // deferred render, the Welcome dialog of a fresh start, a pending script
  // step) starts inside the build.
  pqCoreUtilities::processEvents(QEventLoop::X11ExcludeTimers);
}

//-----------------------------------------------------------------------------
void pqHDTAbortBehavior::onAbortClicked()
{
  vtkAlgorithm* algorithm = this->Running;
  if (!algorithm)
  {
    return;
  }
  // Read by the build's progress callback (CheckAbort) within 50 ms; the
  // executive then empties the outputs.
  algorithm->SetAbortExecuteAndUpdateTime();
  this->Aborted = algorithm;
  this->Running = nullptr;
  if (pqProgressManager* progress = progressManager())
  {
    progress->setEnableAbort(false);
  }
}

//-----------------------------------------------------------------------------
// The algorithm's RequestData has returned (built, failed or aborted): grey
// the button again and clear the flag, or its next run would stop at once.
// (Not at pqProgressManager::progressEndEvent: while the build lets Qt run,
// other short updates begin and end inside it.)
void pqHDTAbortBehavior::onAlgorithmEnd(vtkObject* caller, unsigned long, void*)
{
  vtkAlgorithm* algorithm = vtkAlgorithm::SafeDownCast(caller);
  if (!algorithm || QThread::currentThread() != this->thread())
  {
    return;
  }
  if (algorithm == this->Aborted)
  {
    algorithm->SetAbortExecute(0);
    this->Aborted = nullptr;
  }
  if (algorithm == this->Running)
  {
    this->Running = nullptr;
    if (pqProgressManager* progress = progressManager())
    {
      progress->setEnableAbort(false);
    }
  }
}
