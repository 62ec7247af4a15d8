// The status bar's Abort button for HDT builds in the ParaView 5.11 GUI.
//
// ParaView 5.11 has the button but never makes it usable (Kitware/ParaView at
// v5.11.0): nothing calls pqProgressManager::setEnableAbort(true), so the
// button stays greyed out (Qt/Widgets/pqProgressWidget.cxx creates it
// disabled; Qt/ApplicationComponents/pqStatusBar.cxx only forwards
// enableAbort); nothing listens to pqProgressManager::abort(), so a click would
// reach no algorithm; and pqProgressManager::setProgress no longer calls
// processEvents (commented out there since 3.12), so while a filter runs on
// the GUI thread no click is delivered at all until it has finished.
// ParaView 6.1 added all three (commit 8789e8b2d6, "enable abort button
// functionality"); this class does the same from the plugin, for the HDT
// Voxelizer only (it stops cleanly when asked, within 50 ms inside its long
// loops; the HDT Reader and HDT To Image do not check):
//  - an HDT algorithm reporting progress enables the button, and puts the
//    main window's QWindow on pqProgressManager's non-blockable list: a click
//    from the X server reaches that QWindow first, and the filter would drop
//    it there (a click sent straight to the button widget, as QTest does,
//    passes without it; a real one did not);
//  - floating docks over the button are moved up, clear of it: on any warning
//    ParaView pops its Output Messages dock up over the bottom centre of the
//    main window, status bar included, and every click on the button then
//    landed on that window (the lost clicks of the intermittent GUI test);
//  - each progress report of such a build lets Qt process pending events
//    (at most every 0.1 s, the progress handler's rate). pqProgressManager's
//    event filter still swallows key presses and mouse presses on everything
//    but the progress widget and its button, and views defer renders while
//    progress is pending (pqView::tryRender), so only the click gets through;
//  - a click sets AbortExecute on the HDT algorithm that reported progress;
//    its progress callback sees it within 50 ms (CheckAbort) and the build
//    stops with an empty output;
//  - when the algorithm's RequestData returns, the button is disabled and the
//    flag cleared, so the next Apply builds again.
// Builtin sessions only, as in ParaView 6.1: with a remote server the client
// has no algorithm to flag and the events come from another process.
#ifndef pqHDTAbortBehavior_h
#define pqHDTAbortBehavior_h

#include <QMap>
#include <QObject>
#include <QPointer>
#include <QString>

#include "vtkWeakPointer.h"

class pqPipelineSource;
class pqProgressManager;
class vtkAlgorithm;
class vtkObject;

class pqHDTAbortBehavior : public QObject
{
  Q_OBJECT

public:
  explicit pqHDTAbortBehavior(QObject* parent = nullptr);
  ~pqHDTAbortBehavior() override;

  // Auto-start hooks (paraview_plugin_add_auto_start).
  void startup();
  void shutdown();

  // True for the algorithms whose abort the button offers: vtkHDTVoxelizer
  // and its subclasses, which check CheckAbort while they build.
  static bool isHDTAlgorithm(vtkObject* object);

private Q_SLOTS:
  void watchSource(pqPipelineSource* source);
  void unwatchSource(pqPipelineSource* source);
  void onProgress(const QString& message, int value);
  void onAbortClicked();

private:
  void onAlgorithmProgress(vtkObject* caller, unsigned long event, void* data);
  void onAlgorithmEnd(vtkObject* caller, unsigned long event, void* data);
  static void letClicksReachTheButton(pqProgressManager* progress);
  static void uncoverAbortButton();

  // The algorithm of each watched source and the ids of our observers on it.
  struct Watch
  {
    vtkWeakPointer<vtkAlgorithm> Algorithm;
    unsigned long ProgressObserver = 0;
    unsigned long EndObserver = 0;
  };
  QMap<pqPipelineSource*, Watch> Watches;
  // The HDT algorithm that reported progress in the update under way.
  vtkWeakPointer<vtkAlgorithm> Running;
  // The one the user aborted: its flag is cleared when the update ends.
  vtkWeakPointer<vtkAlgorithm> Aborted;
  bool Started = false;
};

#endif
