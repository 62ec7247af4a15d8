// Test helper for paraview.gui_abort, loaded with ctypes into the running
// ParaView GUI by test_gui_abort.py (same process, same QApplication): where
// the status bar's Abort button is on the screen (x_click.py then clicks
// there through the X server), and what the Properties panel's Resolution
// list offers, which widget is at a screen point; optionally a log of the
// mouse presses. Python in ParaView 5.11 has no Qt bindings of its own.
#include <QApplication>
#include <QComboBox>
#include <QStringList>
#include <QThread>
#include <QToolButton>
#include <QElapsedTimer>
#include <QMouseEvent>
#include <QWidget>

#include <cstdio>

namespace
{
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
QString describe(const QObject* object)
{
  return object ? QString("%1(%2)").arg(object->metaObject()->className(), object->objectName())
                : QString("nothing");
}

// Logs every mouse press and release the application sees, with its receiver,
// the widget under it and the Abort button's state (HDT_TRACE=1).
struct MouseTrace : QObject
{
  QElapsedTimer Clock;
  bool eventFilter(QObject* receiver, QEvent* event) override
  {
    const bool press = event->type() == QEvent::MouseButtonPress;
    if (press || event->type() == QEvent::MouseButtonRelease)
    {
      const QPoint at = static_cast<QMouseEvent*>(event)->globalPos();
      const QToolButton* button = findAbortButton();
      std::fprintf(stderr, "gui_abort trace: %lld ms %s at %d,%d to %s, under it %s; Abort %s\n",
        static_cast<long long>(this->Clock.elapsed()), press ? "press" : "release", at.x(), at.y(),
        qPrintable(describe(receiver)), qPrintable(describe(QApplication::widgetAt(at))),
        button && button->isEnabled() ? "enabled" : "disabled");
    }
    return false;
  }
};
} // namespace

extern "C"
{
  __attribute__((visibility("default"))) void hdt_trace_mouse()
  {
    auto* trace = new MouseTrace;
    trace->Clock.start();
    qApp->installEventFilter(trace);
  }

  // Lets Qt handle the input that came in over the next `ms` milliseconds
  // (timers excluded): clicks the clicker sent just before it was stopped,
  // which would otherwise reach the next build's enabled button.
  __attribute__((visibility("default"))) void hdt_drain_input(int ms)
  {
    QElapsedTimer clock;
    clock.start();
    while (clock.elapsed() < ms)
    {
      QApplication::processEvents(QEventLoop::X11ExcludeTimers);
      QThread::msleep(10);
    }
  }

  // "Class(objectName)" of the widget at a screen point, after letting Qt
  // handle what is pending (a window just shown or moved).
  __attribute__((visibility("default"))) void hdt_widget_at(int x, int y, char* out, int size)
  {
    QApplication::processEvents(QEventLoop::ExcludeUserInputEvents | QEventLoop::X11ExcludeTimers);
    std::snprintf(out, size_t(size), "%s", qPrintable(describe(QApplication::widgetAt(x, y))));
  }

  // The Abort button's centre in screen coordinates (for a click sent through
  // the X server); 0 when found.
  __attribute__((visibility("default"))) int hdt_abort_button_center(int* x, int* y)
  {
    QToolButton* button = findAbortButton();
    if (!button)
    {
      return -1;
    }
    const QPoint centre = button->mapToGlobal(button->rect().center());
    *x = centre.x();
    *y = centre.y();
    return 0;
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
