#include "tool_panel.h"

#include "kiji/tool_event.h"

#include <QButtonGroup>
#include <QCheckBox>
#include <QColorDialog>
#include <QComboBox>
#include <QDoubleSpinBox>
#include <QFormLayout>
#include <QGridLayout>
#include <QHBoxLayout>
#include <QLabel>
#include <QLineEdit>
#include <QMenu>
#include <QPushButton>
#include <QSignalBlocker>
#include <QSlider>
#include <QSpinBox>
#include <QToolButton>
#include <QVBoxLayout>

#include <cmath>
#include <functional>
#include <type_traits>

namespace kiji::studio {

namespace {

constexpr int kSliderSteps = 1000;

bool bounded(const ParamSpec& s) { return s.max > s.min; }

// A slider over a number's range: logarithmic when the range spans several decades (a stiffness
// from 0.01 to 10^6 N/m), so that every decade gets its share of the travel.
struct SliderScale {
  double min, max;
  bool log;
  explicit SliderScale(const ParamSpec& s) : min(s.min), max(s.max), log(s.min > 0 && s.max / s.min >= 100) {}
  int to_slider(double v) const {
    const double x = log ? (std::log(v) - std::log(min)) / (std::log(max) - std::log(min)) : (v - min) / (max - min);
    return static_cast<int>(std::lround(std::clamp(x, 0.0, 1.0) * kSliderSteps));
  }
  double from_slider(int i) const {
    const double x = double(i) / kSliderSteps;
    return log ? std::exp(std::log(min) + x * (std::log(max) - std::log(min))) : min + x * (max - min);
  }
};

QString unit_suffix(const ParamSpec& s) { return s.unit.empty() ? QString() : " " + QString::fromStdString(s.unit); }

// Three significant digits of the default, and enough for the smallest value allowed.
int decimals_for(const ParamSpec& s) {
  const double d = std::abs(std::get<double>(s.default_value));
  const double base = d > 0 ? d : (s.min > 0 ? s.min : 1.0);
  int decimals = 3 - static_cast<int>(std::floor(std::log10(base)));
  if (s.min > 0) decimals = std::max(decimals, static_cast<int>(std::ceil(-std::log10(s.min))));
  return std::clamp(decimals, 0, 6);
}

QColor to_qcolor(const Vec3& c) {
  return QColor::fromRgbF(float(std::clamp(c.x(), 0.0, 1.0)), float(std::clamp(c.y(), 0.0, 1.0)),
                          float(std::clamp(c.z(), 0.0, 1.0)));
}

void show_colour(QPushButton* b, const Vec3& c) {
  const QColor q = to_qcolor(c);
  b->setText(q.name());
  b->setStyleSheet(QString("background-color: %1; color: %2;").arg(q.name(), q.lightnessF() > 0.5 ? "black" : "white"));
}

// A spin box that lets a number outside its range be typed, then takes the nearest end of the range
// and says what it did (Qt's own refuses the keystroke without a word: 5000000 became 500000).
template <typename Base>
class RangeSpinBox : public Base {
 public:
  using Value = decltype(std::declval<Base>().value());
  std::function<void(double typed, Value taken)> clamped;

  QValidator::State validate(QString& text, int& pos) const override {
    const QValidator::State state = Base::validate(text, pos);
    if (state != QValidator::Invalid) return state;
    bool ok = false;
    parse(text, &ok);
    return ok ? QValidator::Intermediate : state;  // a number: out of range, fixed up when left
  }
  void fixup(QString& text) const override {
    bool ok = false;
    const double typed = parse(text, &ok);
    if (ok && (typed < double(this->minimum()) || typed > double(this->maximum()))) {
      const Value taken = typed < double(this->minimum()) ? this->minimum() : this->maximum();
      text = this->textFromValue(taken);
      if (clamped) clamped(typed, taken);
      return;
    }
    Base::fixup(text);
  }

 private:
  double parse(QString text, bool* ok) const {
    text = text.trimmed();
    if (!this->suffix().isEmpty() && text.endsWith(this->suffix().trimmed())) text.chop(this->suffix().trimmed().size());
    return this->locale().toDouble(text.trimmed(), ok);
  }
};

// A number's editor: its spin box (the unit as a suffix) with, for a bounded range, a slider kept in
// step with it; `changed` gets every new value.
template <typename SpinBox>
QWidget* number_row(const ParamSpec& spec, SpinBox* spin, std::function<void(double)> changed) {
  auto* row = new QWidget;
  auto* h = new QHBoxLayout(row);
  h->setContentsMargins(0, 0, 0, 0);
  spin->setParent(row);
  spin->setObjectName("spin");
  spin->setSuffix(unit_suffix(spec));
  using Value = decltype(spin->value());
  if (bounded(spec)) {
    auto* slider = new QSlider(Qt::Horizontal, row);
    slider->setObjectName("slider");
    const SliderScale scale(spec);
    slider->setRange(0, kSliderSteps);
    slider->setValue(scale.to_slider(double(spin->value())));
    QObject::connect(slider, &QSlider::valueChanged, spin, [spin, scale](int i) {
      const double v = scale.from_slider(i);
      spin->setValue(std::is_integral_v<Value> ? Value(std::lround(v)) : Value(v));
    });
    QObject::connect(spin, qOverload<Value>(&SpinBox::valueChanged), slider, [slider, scale](Value v) {
      const QSignalBlocker block(slider);
      slider->setValue(scale.to_slider(double(v)));
    });
    h->addWidget(slider, 2);
  }
  h->addWidget(spin, 1);
  QObject::connect(spin, qOverload<Value>(&SpinBox::valueChanged), row,
                   [changed = std::move(changed)](Value v) { changed(double(v)); });
  return row;
}

}  // namespace

ParamPanel::ParamPanel(QWidget* parent) : QWidget(parent) {
  auto* layout = new QVBoxLayout(this);
  title_ = new QLabel(this);
  title_->setObjectName("tool_title");
  QFont f = title_->font();
  f.setBold(true);
  title_->setFont(f);
  description_ = new QLabel(this);
  description_->setWordWrap(true);
  form_ = new QFormLayout;
  layout->addWidget(title_);
  layout->addWidget(description_);
  layout->addLayout(form_);
  layout->addStretch(1);
}

QWidget* ParamPanel::editor(const std::string& name) const {
  const auto it = editors_.find(name);
  return it == editors_.end() ? nullptr : it->second;
}

void ParamPanel::set(const std::string& name, const ParamValue& value) {
  try {
    values_.set(name, value);
  } catch (const std::exception&) {
    return;  // the widgets keep to the declared range; a value outside it is not taken
  }
  emit changed(values_);
}

void ParamPanel::say_clamped(const ParamSpec& spec, double typed, double taken) {
  const QString unit = spec.unit.empty() ? QString() : " " + QString::fromStdString(spec.unit);
  const QString label = QString::fromStdString(spec.label.empty() ? spec.name : spec.label);
  emit said(QString("%1: %2%3 is %4 the range %5 to %6%3, so %7%3 is used")
                .arg(label)
                .arg(typed, 0, 'g', 8)
                .arg(unit)
                .arg(typed > taken ? "above" : "below")
                .arg(spec.min, 0, 'g', 8)
                .arg(spec.max, 0, 'g', 8)
                .arg(taken, 0, 'g', 8));
}

QWidget* ParamPanel::make_editor(const ParamSpec& spec) {
  const std::string name = spec.name;
  const ParamValue value = values_.get(name);
  QWidget* editor = nullptr;
  switch (spec.type) {
    case ParamType::Bool: {
      auto* box = new QCheckBox(this);
      box->setChecked(std::get<bool>(value));
      connect(box, &QCheckBox::toggled, this, [this, name](bool on) { set(name, on); });
      editor = box;
      break;
    }
    case ParamType::Int: {
      auto* spin = new RangeSpinBox<QSpinBox>();
      spin->setCorrectionMode(QAbstractSpinBox::CorrectToNearestValue);
      spin->clamped = [this, spec](double typed, int taken) { say_clamped(spec, typed, double(taken)); };
      const bool b = bounded(spec);
      spin->setRange(b ? int(spec.min) : -2147483647, b ? int(spec.max) : 2147483647);
      spin->setValue(int(std::get<long long>(value)));
      editor = number_row(spec, spin, [this, name](double v) { set(name, (long long)std::llround(v)); });
      break;
    }
    case ParamType::Float: {
      auto* spin = new RangeSpinBox<QDoubleSpinBox>();
      spin->setCorrectionMode(QAbstractSpinBox::CorrectToNearestValue);
      spin->clamped = [this, spec](double typed, double taken) { say_clamped(spec, typed, taken); };
      const bool b = bounded(spec);
      spin->setDecimals(decimals_for(spec));
      spin->setRange(b ? spec.min : -1e12, b ? spec.max : 1e12);
      spin->setSingleStep(std::pow(10.0, -spin->decimals() + 1));
      spin->setValue(std::get<double>(value));
      editor = number_row(spec, spin, [this, name](double v) { set(name, v); });
      break;
    }
    case ParamType::Choice: {
      auto* combo = new QComboBox(this);
      for (const std::string& c : spec.choices) combo->addItem(QString::fromStdString(c));
      combo->setCurrentText(QString::fromStdString(std::get<std::string>(value)));
      connect(combo, &QComboBox::currentTextChanged, this, [this, name](const QString& t) { set(name, t.toStdString()); });
      editor = combo;
      break;
    }
    case ParamType::String: {
      auto* line = new QLineEdit(QString::fromStdString(std::get<std::string>(value)), this);
      connect(line, &QLineEdit::editingFinished, this, [this, name, line] { set(name, line->text().toStdString()); });
      editor = line;
      break;
    }
    case ParamType::Color: {
      auto* button = new QPushButton(this);
      show_colour(button, std::get<Vec3>(value));
      connect(button, &QPushButton::clicked, this, [this, name, button] {
        const QColor chosen = QColorDialog::getColor(to_qcolor(values_.get_color(name)), this, "Colour");
        if (!chosen.isValid()) return;
        const Vec3 c(chosen.redF(), chosen.greenF(), chosen.blueF());
        show_colour(button, c);
        set(name, c);
      });
      editor = button;
      break;
    }
  }
  editor->setObjectName(QString::fromStdString("param_" + name));
  const QString help = QString::fromStdString(spec.help);
  editor->setToolTip(help);
  for (QWidget* child : editor->findChildren<QWidget*>()) child->setToolTip(help);
  return editor;
}

void ParamPanel::show_tool(const ToolInfo& info, const ParamSet& values) {
  while (form_->rowCount() > 0) form_->removeRow(0);
  editors_.clear();
  values_ = values;
  title_->setText(QString::fromStdString(info.label));
  description_->setText(QString::fromStdString(info.description));
  for (const ParamSpec& spec : info.parameters) {
    QWidget* e = make_editor(spec);
    auto* label = new QLabel(QString::fromStdString(spec.label.empty() ? spec.name : spec.label), this);
    label->setToolTip(QString::fromStdString(spec.help));
    form_->addRow(label, e);
    editors_[spec.name] = e;
  }
}

ToolPanel::ToolPanel(const ToolRegistry& tools, QWidget* parent) : QWidget(parent), tools_(tools) {
  auto* layout = new QVBoxLayout(this);
  auto* grid = new QGridLayout;
  group_ = new QButtonGroup(this);
  group_->setExclusive(true);
  int i = 0;
  for (const std::string& id : tools.ids()) {
    const ToolInfo info = tools.info(id);
    auto* b = new QToolButton(this);
    b->setObjectName(QString::fromStdString("tool_" + id));
    b->setText(QString::fromStdString(info.label.empty() ? id : info.label));
    b->setToolTip(QString::fromStdString(info.description + "\nRight-click: use with the secondary button."));
    b->setCheckable(true);
    b->setToolButtonStyle(Qt::ToolButtonTextOnly);
    b->setSizePolicy(QSizePolicy::Expanding, QSizePolicy::Fixed);
    b->setContextMenuPolicy(Qt::CustomContextMenu);
    connect(b, &QToolButton::clicked, this, [this, id] { choose(id, kButtonPrimary); });
    connect(b, &QToolButton::customContextMenuRequested, this, [this, id, b](const QPoint& at) {
      QMenu menu;
      menu.addAction("Use with the primary button (left)", this, [this, id] { choose(id, kButtonPrimary); });
      menu.addAction("Use with the secondary button (right)", this, [this, id] { choose(id, kButtonSecondary); });
      menu.exec(b->mapToGlobal(at));
    });
    group_->addButton(b);
    grid->addWidget(b, i / 2, i % 2);
    buttons_[id] = b;
    values_[id] = ParamSet(info.parameters);
    // A seam sewn by hand closes as the cloth is drawn together, as in garment tools; the tool's own
    // default (at once) is what scripts and earlier journals have.
    if (id == "sew" && values_[id].values().count("join")) values_[id].set("join", std::string("closing"));
    ++i;
  }
  layout->addLayout(grid);
  secondary_label_ = new QLabel(this);
  secondary_label_->setObjectName("secondary_tool");
  secondary_label_->setWordWrap(true);
  secondary_label_->setToolTip("Right-click a tool to put it on the right button");
  layout->addWidget(secondary_label_);
  panel_ = new ParamPanel(this);
  layout->addWidget(panel_, 1);
  connect(panel_, &ParamPanel::said, this, &ToolPanel::said);
  connect(panel_, &ParamPanel::changed, this, [this](const ParamSet& p) {
    values_[primary_] = p;
    emit tool_changed(kButtonPrimary, primary_, p);
    if (secondary_ == primary_) emit tool_changed(kButtonSecondary, secondary_, p);
  });
  if (tools.ids().empty()) secondary_label_->setText("No tools were found: see Help > Plugins.");
}

QWidget* ToolPanel::button(const std::string& id) const {
  const auto it = buttons_.find(id);
  return it == buttons_.end() ? nullptr : it->second;
}

ParamSet ToolPanel::params_of(const std::string& id) const {
  const auto it = values_.find(id);
  return it == values_.end() ? ParamSet{} : it->second;
}

void ToolPanel::choose(const std::string& id, std::uint32_t button) {
  if (!tools_.has(id)) return;
  if (button == kButtonSecondary) {
    secondary_ = id;
    // Put back on the primary's tool, the secondary follows it again.
    secondary_chosen_ = id != primary_;
  } else {
    primary_ = id;
    if (auto* b = qobject_cast<QToolButton*>(this->button(id))) b->setChecked(true);
    panel_->show_tool(tools_.info(id), values_[id]);
    if (!secondary_chosen_) secondary_ = id;
  }
  secondary_label_->setText(QString("Right button: %1%2")
                                .arg(QString::fromStdString(tools_.info(secondary_).label))
                                .arg(secondary_chosen_ ? "" : " (as the left)"));
  emit tool_changed(button, id, values_[id]);
  if (button == kButtonPrimary && secondary_ == id) emit tool_changed(kButtonSecondary, id, values_[id]);
}

}  // namespace kiji::studio
