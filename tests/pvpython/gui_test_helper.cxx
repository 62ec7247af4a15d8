// Test helper for paraview.gui_abort: the user who clicks the status bar's
// Abort button while a build runs, and who reads the Resolution list. Loaded with ctypes into the running
// ParaView GUI by test_gui_abort.py (same process, same QApplication).
//
// hdt_schedule_abort_click(ms, png) starts a thread that, ms later, posts to
// the GUI thread's event queue (as the X server's click arrives there): grab
// the main window into png, then click the button "AbortButton" with QTest (a
// press and a release through QApplication::notify, so through ParaView's
// event filter as a real click). Posted events are handled only when Qt
// processes events: if nothing lets Qt run during the build, the click comes
// after the build, too late, and the test sees a finished build. (Not a Qt
// timer: the plugin lets Qt handle input during a build, not timers.) hdt_abort_click_state() tells what
// happened: 0 not yet fired, 1 fired on a greyed-out button, 2 clicked an
// enabled button.
#include <QApplication>
#include <QComboBox>
#include <QStringList>
#include <QPixmap>
#include <QString>
#include <QMetaObject>
#include <QPointer>
#include <QToolButton>
#include <QWidget>
#include <QtTest/QTest>

#include <chrono>
#include <cstdio>
#include <thread>

namespace
{
int clickState = 0;

QToolButton* findAbortButton()
{
  for (QWidget* widget : QApplication::allWidgets())
  {
    if (widget->objectName() == QLatin1String("AbortButton"))
    {
      if (auto* button = qobject_cast<QToolButton*>(widget))
      {
        return button;
      }
    }
  }
  return nullptr;
}
} // namespace

extern "C"
{
  __attribute__((visibility("default"))) int hdt_schedule_abort_click(int delayMs, const char* png)
  {
    if (!qobject_cast<QApplication*>(QCoreApplication::instance()))
    {
      return -1;
    }
    QToolButton* button = findAbortButton();
    if (!button)
    {
      return -2;
    }
    clickState = 0;
    const QString pngPath = QString::fromUtf8(png ? png : "");
    QPointer<QToolButton> target(button);
    std::thread([delayMs, target, pngPath]() {
      std::this_thread::sleep_for(std::chrono::milliseconds(delayMs));
      QToolButton* b = target.data();
      if (!b)
      {
        return;
      }
      QMetaObject::invokeMethod(
        b,
        [b, pngPath]() {
          if (!pngPath.isEmpty())
          {
            b->window()->grab().save(pngPath);
          }
          clickState = b->isEnabled() ? 2 : 1;
          QTest::mouseClick(b, Qt::LeftButton);
        },
        Qt::QueuedConnection);
    }).detach();
    return 0;
  }

  __attribute__((visibility("default"))) int hdt_abort_click_state()
  {
    return clickState;
  }

  // The items of the combo box in the Properties panel's widget for the named
  // property (pqProxyWidget names each property widget after its property),
  // comma-separated into out; the number of items, or -1 when not found.
  __attribute__((visibility("default"))) int hdt_panel_combo_items(
    const char* property, char* out, int size)
  {
    for (QWidget* widget : QApplication::allWidgets())
    {
      auto* combo = qobject_cast<QComboBox*>(widget);
      if (!combo || !combo->isVisible())
      {
        continue;
      }
      for (QWidget* up = combo->parentWidget(); up; up = up->parentWidget())
      {
        if (up->objectName() == QLatin1String(property))
        {
          QStringList items;
          for (int i = 0; i < combo->count(); ++i)
          {
            items << combo->itemText(i);
          }
          const QByteArray text = items.join(',').toUtf8();
          std::snprintf(out, size_t(size), "%s", text.constData());
          return combo->count();
        }
      }
    }
    return -1;
  }
}
