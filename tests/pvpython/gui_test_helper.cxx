// Test helper for paraview.gui_abort, loaded with ctypes into the running
// ParaView GUI by test_gui_abort.py (same process, same QApplication): where
// the status bar's Abort button is on the screen (x_click.py then clicks
// there through the X server), and what the Properties panel's Resolution
// list offers. Python in ParaView 5.11 has no Qt bindings of its own.
#include <QApplication>
#include <QComboBox>
#include <QStringList>
#include <QToolButton>
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
} // namespace

extern "C"
{
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
