// The tool palette and the parameter panel, both generated from the tools' declarations: every
// tool found at run time gets a button, and the chosen tool's ParamSpecs become widgets (a slider
// and a spin box with unit and range for numbers, a check box, a combo box of choices, a colour
// picker, a text field), each with the parameter's help as its tooltip. The app names no tool.
#pragma once

#include "kiji/params.h"
#include "kiji/plugin_loader.h"

#include <QWidget>

#include <functional>
#include <map>

class QButtonGroup;
class QFormLayout;
class QLabel;
class QVBoxLayout;

namespace kiji::studio {

// The widgets of one tool's parameters. A number typed outside its range is taken at the nearest
// end of the range, and the panel says so (said()).
class ParamPanel : public QWidget {
  Q_OBJECT
 public:
  explicit ParamPanel(QWidget* parent = nullptr);
  // Builds the widgets for `info`'s parameters, showing `values`.
  void show_tool(const ToolInfo& info, const ParamSet& values);
  const ParamSet& values() const { return values_; }
  // The widget of a parameter (its objectName is "param_<name>"), or null.
  QWidget* editor(const std::string& name) const;

 signals:
  void changed(const kiji::ParamSet& values);
  // A message for the user (a value typed out of range and what was taken instead).
  void said(const QString& text);

 private:
  void set(const std::string& name, const ParamValue& value);
  void say_clamped(const ParamSpec& spec, double typed, double taken);
  QWidget* make_editor(const ParamSpec& spec);

  ParamSet values_;
  QFormLayout* form_;
  QLabel* title_;
  QLabel* description_;
  std::map<std::string, QWidget*> editors_;
};

// The palette of tools and the panel of the chosen one.
class ToolPanel : public QWidget {
  Q_OBJECT
 public:
  explicit ToolPanel(const ToolRegistry& tools, QWidget* parent = nullptr);
  // Chooses the tool for a button (kButtonPrimary or kButtonSecondary). The secondary button uses the
  // primary's tool until a tool is put on it (a right-click on its button in the palette).
  void choose(const std::string& id, std::uint32_t button = 1);
  const std::string& primary() const { return primary_; }
  const std::string& secondary() const { return secondary_; }
  ParamPanel& params() { return *panel_; }
  ParamSet params_of(const std::string& id) const;
  // The palette's button of a tool (objectName "tool_<id>").
  QWidget* button(const std::string& id) const;

 signals:
  // A button's tool or its parameters changed.
  void tool_changed(std::uint32_t button, const std::string& id, const kiji::ParamSet& params);
  void said(const QString& text);

 private:
  const ToolRegistry& tools_;
  std::string primary_, secondary_;
  bool secondary_chosen_ = false;  // a tool was put on the secondary button: it no longer follows
  std::map<std::string, ParamSet> values_;  // each tool's parameters, kept while another is chosen
  QButtonGroup* group_;
  QLabel* secondary_label_;
  ParamPanel* panel_;
  std::map<std::string, QWidget*> buttons_;
};

}  // namespace kiji::studio
