#include "main_window.h"

#include "peers_panel.h"
#include "python_console.h"
#include "tool_panel.h"

#include "kiji/material.h"
#include "kiji/session.h"
#include "kiji/version.h"

#include <QActionGroup>
#include <QApplication>
#include <QCheckBox>
#include <QCloseEvent>
#include <QComboBox>
#include <QDateTime>
#include <QDialog>
#include <QDialogButtonBox>
#include <QDockWidget>
#include <QDoubleSpinBox>
#include <QFileDialog>
#include <QFormLayout>
#include <QColor>
#include <QFile>
#include <QHBoxLayout>
#include <QInputDialog>
#include <QJsonDocument>
#include <QJsonObject>
#include <QPushButton>
#include <QLabel>
#include <QPlainTextEdit>
#include <QTextEdit>
#include <QAbstractSpinBox>
#include <QLineEdit>
#include <QMenuBar>
#include <QMessageBox>
#include <QPainter>
#include <QStatusBar>
#include <QTextStream>

#include <cctype>
#include <map>
#include <set>
#include <tuple>

#include <cstdio>

namespace kiji::studio {

namespace {

QDoubleSpinBox* number(QWidget* parent, double value, double min, double max, int decimals, const QString& suffix) {
  auto* s = new QDoubleSpinBox(parent);
  s->setRange(min, max);
  s->setDecimals(decimals);
  s->setValue(value);
  s->setSuffix(suffix);
  return s;
}

// "x,y; x,y; ..." as a panel's outline.
std::vector<Vec2> parse_outline(const QString& text) {
  std::vector<Vec2> out;
  for (const QString& point : text.split(';', Qt::SkipEmptyParts)) {
    const QStringList xy = point.split(',', Qt::SkipEmptyParts);
    bool ok_x = false, ok_y = false;
    if (xy.size() != 2) throw InputError("outline point '" + point.trimmed().toStdString() + "' is not 'x, y'");
    const double x = xy[0].trimmed().toDouble(&ok_x), y = xy[1].trimmed().toDouble(&ok_y);
    if (!ok_x || !ok_y) throw InputError("outline point '" + point.trimmed().toStdString() + "' has a coordinate that is not a number");
    out.emplace_back(x, y);
  }
  return out;
}

}  // namespace

MainWindow::MainWindow(Studio& studio, QWidget* parent) : QMainWindow(parent), studio_(studio) {
  setWindowTitle("Kiji Studio");
  viewport_ = new Viewport(studio);
  setCentralWidget(viewport_->widget(this));

  tools_ = new ToolPanel(studio.tools(), this);
  tools_dock_ = new QDockWidget("Tools", this);
  tools_dock_->setObjectName("tools_dock");
  tools_dock_->setWidget(tools_);
  addDockWidget(Qt::LeftDockWidgetArea, tools_dock_);
  connect(tools_, &ToolPanel::tool_changed, this,
          [this](std::uint32_t button, const std::string& id, const ParamSet& p) { studio_.set_tool(button, id, p); });

  console_ = new PythonConsole(studio, this);
  console_dock_ = new QDockWidget("Python", this);
  console_dock_->setObjectName("console_dock");
  console_dock_->setWidget(console_);
  addDockWidget(Qt::BottomDockWidgetArea, console_dock_);

  peers_ = new PeersPanel(studio, this);
  peers_dock_ = new QDockWidget("Peers", this);
  peers_dock_->setObjectName("peers_dock");
  peers_dock_->setWidget(peers_);
  addDockWidget(Qt::RightDockWidgetArea, peers_dock_);
  peers_dock_->hide();  // shown when the session is shared

  status_sim_ = new QLabel(this);
  status_fps_ = new QLabel(this);
  status_haptic_ = new QLabel(this);
  status_vertices_ = new QLabel(this);
  status_tool_ = new QLabel(this);
  status_shared_ = new QLabel(this);
  status_hint_ = new QLabel(this);
  status_hint_->setObjectName("hint");
  statusBar()->addWidget(status_hint_, 1);
  for (QLabel* l : {status_sim_, status_fps_, status_haptic_, status_vertices_, status_tool_, status_shared_})
    statusBar()->addPermanentWidget(l);

  build_menus();
  connect(&studio, &Studio::message, this, &MainWindow::on_message);
  connect(&studio, &Studio::file_changed, this, &MainWindow::update_title);
  connect(viewport_, &Viewport::hint, status_hint_, &QLabel::setText);
  connect(tools_, &ToolPanel::said, this, [this](const QString& text) { on_message(text, false); });
  connect(&studio, &Studio::scene_changed, viewport_, &Viewport::frame_all);
  connect(&studio, &Studio::device_changed, this, &MainWindow::sync_device_menu);
  connect(&studio, &Studio::sharing_changed, this, [this] {
    leave_action_->setEnabled(studio_.shared());
    if (studio_.shared()) peers_dock_->show();
  });
  connect(viewport_, &Viewport::gl_failed, this, [this](const QString& why) { on_message(why, true); });
  auto* timer = new QTimer(this);
  connect(timer, &QTimer::timeout, this, &MainWindow::update_status);
  timer->start(500);

  // The first tool, so that a button does something from the start.
  const auto ids = studio.tools().ids();
  if (!ids.empty()) tools_->choose(std::find(ids.begin(), ids.end(), "pinch") != ids.end() ? "pinch" : ids.front());
  resize(1280, 800);
  // The view gets the room; the console a few lines, until the user drags it taller.
  resizeDocks({console_dock_}, {150}, Qt::Vertical);
  resizeDocks({tools_dock_}, {300}, Qt::Horizontal);
}

MainWindow::~MainWindow() = default;

void MainWindow::closeEvent(QCloseEvent* e) {
  if (!maybe_save()) {
    e->ignore();
    return;
  }
  studio_.cancel_drape();
  QMainWindow::closeEvent(e);
}

void MainWindow::update_title() {
  const QString file = studio_.file();
  setWindowTitle(QString("%1[*] - Kiji Studio").arg(file.isEmpty() ? QString("Untitled") : QFileInfo(file).fileName()));
  setWindowModified(studio_.modified());
}

bool MainWindow::maybe_save() {
  if (!studio_.modified()) return true;
  const QString name = studio_.file().isEmpty() ? QString("The session") : QFileInfo(studio_.file()).fileName();
  const auto answer = QMessageBox::warning(this, "Kiji Studio", name + " has changes that are not saved. Save them?",
                                           QMessageBox::Save | QMessageBox::Discard | QMessageBox::Cancel,
                                           QMessageBox::Save);
  if (answer == QMessageBox::Save) return save();
  return answer == QMessageBox::Discard;
}

bool MainWindow::save() {
  if (studio_.file().isEmpty()) return save_as();
  return studio_.save_session(studio_.file());
}

bool MainWindow::save_as() {
  QString path = QFileDialog::getSaveFileName(this, "Save session", studio_.file(), "Kiji Studio sessions (*.kiji)");
  if (path.isEmpty()) return false;
  if (!path.endsWith(".kiji")) path += ".kiji";
  return studio_.save_session(path);
}

bool MainWindow::offer_recovery() {
  const QStringList left = studio_.unfinished_autosaves();
  if (left.isEmpty()) return false;
  QString when = QFileInfo(left.front()).lastModified().toString("hh:mm 'on' d MMMM yyyy");
  if (left.size() > 1) when += QString("; %1 older one%2 too").arg(left.size() - 1).arg(left.size() > 2 ? "s" : "");
  QMessageBox box(QMessageBox::Question, "Recover a session",
                  QString("Kiji Studio did not quit cleanly. The session it was working on was autosaved "
                          "(last at %1).\n\nRecover it?")
                      .arg(when),
                  QMessageBox::NoButton, this);
  QPushButton* recover = box.addButton("Recover", QMessageBox::AcceptRole);
  QPushButton* discard = box.addButton("Discard", QMessageBox::DestructiveRole);
  box.addButton("Not now", QMessageBox::RejectRole);
  box.setDefaultButton(recover);
  box.exec();
  if (box.clickedButton() == discard) {
    for (const QString& f : left) studio_.discard_autosave(f);
    on_message("The autosaved sessions were discarded", false);
    return false;
  }
  if (box.clickedButton() != recover) return false;
  return studio_.recover(left.front());
}

void MainWindow::delete_selected_piece() {
  const Viewport::Selection s = viewport_->selection();
  if (s.garment < 0) {
    on_message("Nothing is selected: Ctrl + click a piece of cloth first", false);
    return;
  }
  viewport_->clear_selection();
  studio_.remove_piece(s.garment, s.vertex);
}

void MainWindow::undo_or_redo(bool redo) {
  // A text field with the keyboard (the console's input, a parameter's box) takes its own undo.
  QWidget* focus = QApplication::focusWidget();
  if (auto* line = qobject_cast<QLineEdit*>(focus)) {
    redo ? line->redo() : line->undo();
    return;
  }
  if (auto* text = qobject_cast<QPlainTextEdit*>(focus); text && !text->isReadOnly()) {
    redo ? text->redo() : text->undo();
    return;
  }
  if (auto* spin = qobject_cast<QAbstractSpinBox*>(focus)) {
    if (auto* line = spin->findChild<QLineEdit*>()) redo ? line->redo() : line->undo();
    return;
  }
  redo ? studio_.redo() : studio_.undo();
}

void MainWindow::build_menus() {
  QMenu* file = menuBar()->addMenu("&File");
  file->addAction("&New scene", QKeySequence::New, this, [this] {
    if (maybe_save()) studio_.new_scene();
  });
  file->addAction("Open &body...", this, &MainWindow::open_body_dialog);
  file->addAction("New &garment...", this, &MainWindow::new_garment_dialog);
  file->addSeparator();
  file->addAction("&Open session...", QKeySequence::Open, this, [this] {
    if (!maybe_save()) return;
    const QString path = QFileDialog::getOpenFileName(this, "Open session", {}, "Kiji Studio sessions (*.kiji)");
    if (!path.isEmpty()) studio_.open_session(path);
  });
  file->addAction("&Save session", QKeySequence::Save, this, [this] { save(); });
  file->addAction("Save session &as...", QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_S), this, [this] { save_as(); });
  file->addAction("&Replay journal...", this, [this] {
    const QString path = QFileDialog::getOpenFileName(this, "Replay journal", {}, "Journals (*.journal *.json);;All files (*)");
    if (!path.isEmpty()) studio_.replay(path);
  });
  file->addAction("Save &journal...", this, [this] {
    const QString path = QFileDialog::getSaveFileName(this, "Save journal", {}, "Journals (*.journal)");
    if (!path.isEmpty()) studio_.save_journal(path);
  });
  file->addAction("&Export garment...", this, [this] {
    const QString path = QFileDialog::getSaveFileName(this, "Export garment", {}, "glTF binary (*.glb);;Wavefront OBJ (*.obj)");
    if (!path.isEmpty()) studio_.export_garment(path);
  });
  file->addAction("Save &picture...", this, [this] {
    const QString path = QFileDialog::getSaveFileName(this, "Save picture", {}, "PNG (*.png)");
    if (!path.isEmpty()) save_picture(path);
  });
  file->addSeparator();
  file->addAction("&Host session...", this, [this] { share_dialog(true); });
  // Joining keeps this session to come back to (Leave session): nothing to save first.
  file->addAction("&Join session...", this, [this] { share_dialog(false); });
  leave_action_ = file->addAction("&Leave session", this, [this] {
    studio_.leave_session();
    on_message("Left the shared session: the session is yours alone again", false);
  });
  leave_action_->setEnabled(false);
  file->addSeparator();
  file->addAction("&Quit", QKeySequence::Quit, this, &QWidget::close);
  update_title();

  QMenu* edit = menuBar()->addMenu("&Edit");
  undo_action_ = edit->addAction("&Undo", QKeySequence(Qt::CTRL | Qt::Key_Z), this, [this] { undo_or_redo(false); });
  redo_action_ =
      edit->addAction("&Redo", QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_Z), this, [this] { undo_or_redo(true); });
  edit->addSeparator();
  QAction* select = edit->addAction("&Select a piece: Ctrl + click it");
  select->setEnabled(false);
  QAction* remove = edit->addAction("&Delete the selected piece", this, &MainWindow::delete_selected_piece);
  remove->setShortcuts({QKeySequence(Qt::Key_Delete), QKeySequence(Qt::Key_Backspace), QKeySequence(Qt::Key_X)});

  QMenu* view = menuBar()->addMenu("&View");
  view->addAction("&Frame all", QKeySequence(Qt::Key_F), viewport_, &Viewport::frame_all);
  const std::tuple<const char*, QKeySequence, Viewport::View> views[] = {
      {"Fr&ont", QKeySequence(Qt::Key_1), Viewport::View::Front},
      {"&Back", QKeySequence(Qt::CTRL | Qt::Key_1), Viewport::View::Back},
      {"&Right side", QKeySequence(Qt::Key_3), Viewport::View::Right},
      {"&Left side", QKeySequence(Qt::CTRL | Qt::Key_3), Viewport::View::Left},
      {"&Top", QKeySequence(Qt::Key_7), Viewport::View::Top}};
  for (const auto& [label, keys, which] : views)
    view->addAction(label, keys, this, [this, which = which] { viewport_->set_view(which); });
  view->addSeparator();
  QMenu* edges = view->addMenu("&Edges and vertices");
  edges_group_ = new QActionGroup(this);
  const std::pair<const char*, EdgeDisplay> modes[] = {
      {"&Everywhere", EdgeDisplay::All}, {"Around the &pointer", EdgeDisplay::Local}, {"&None", EdgeDisplay::None}};
  for (const auto& [label, mode] : modes) {
    QAction* a = edges->addAction(label, this, [this, mode = mode] { set_edge_display(mode); });
    a->setCheckable(true);
    a->setData(int(mode));
    a->setChecked(mode == viewport_->draw_options().edges);
    edges_group_->addAction(a);
  }
  edges->addAction("Region &radius...", this, [this] {
    bool ok = false;
    const double r = QInputDialog::getDouble(this, "Region radius", "Edges and vertices are drawn within (m):",
                                             viewport_->draw_options().local_radius, 0.005, 10, 3, &ok);
    if (ok) viewport_->draw_options().local_radius = r;
  });
  QAction* body = view->addAction("Show &body", this, [this](bool on) { viewport_->draw_options().show_body = on; });
  body->setCheckable(true);
  body->setChecked(true);
  QAction* floor = view->addAction("Show f&loor", this, [this](bool on) { viewport_->draw_options().show_floor = on; });
  floor->setCheckable(true);
  floor->setChecked(true);
  view->addSeparator();
  view->addAction(tools_dock_->toggleViewAction());
  view->addAction(console_dock_->toggleViewAction());
  view->addAction(peers_dock_->toggleViewAction());

  // The tools, each on a key: the verb's first letter where it is free.
  QMenu* tools = menuBar()->addMenu("T&ools");
  const std::map<std::string, Qt::Key> preferred = {{"pinch", Qt::Key_P}, {"tear", Qt::Key_T}, {"cut", Qt::Key_C},
                                                    {"sew", Qt::Key_S}, {"paint", Qt::Key_B}, {"pin", Qt::Key_I}};
  std::set<int> taken = {Qt::Key_F, Qt::Key_R, Qt::Key_X};  // frame all; turn a seam; delete a piece
  for (const auto& [id, key] : preferred)
    if (studio_.tools().has(id)) taken.insert(key);
  for (const std::string& id : studio_.tools().ids()) {
    int key = 0;
    if (const auto it = preferred.find(id); it != preferred.end()) key = it->second;
    for (std::size_t i = 0; key == 0 && i < id.size(); ++i) {
      const int k = Qt::Key_A + (std::toupper(static_cast<unsigned char>(id[i])) - 'A');
      if (std::isalpha(static_cast<unsigned char>(id[i])) && !taken.count(k)) key = k, taken.insert(k);
    }
    const QString label = QString::fromStdString(studio_.tools().info(id).label);
    QAction* a = tools->addAction(label, this, [this, id = id] { tools_->choose(id); });
    if (key) a->setShortcut(QKeySequence(key));
  }

  QMenu* sim = menuBar()->addMenu("&Simulation");
  run_action_ = sim->addAction("&Run", QKeySequence(Qt::Key_Space), this, [this](bool on) { studio_.set_simulating(on); });
  run_action_->setCheckable(true);
  run_action_->setChecked(true);
  // A new garment drapes coarse first, in seconds; step by step it falls as the session steps it
  // throughout, a few times as long, and lands with less of the stretch the copy's landing leaves.
  for (const bool coarse : {true, false})
    sim->addAction(coarse ? "&Drape..." : "Drape step by step...", this, [this, coarse] {
      bool ok = false;
      const double s = QInputDialog::getDouble(this, coarse ? "Drape" : "Drape step by step",
                                               "Simulated seconds to let the garments fall and settle:", 3.0, 0.1, 60, 1,
                                               &ok);
      if (ok) studio_.drape(s, coarse);
    });
  sim->addAction("Stop draping", this, [this] { studio_.cancel_drape(); });
  sim->addAction("R&eset", this, [this] {
    if (QMessageBox::question(this, "Reset", "Put the scene back as it was set up? Every stroke is dropped.") ==
        QMessageBox::Yes)
      studio_.reset();
  });

  QMenu* device = menuBar()->addMenu("&Device");
  device_group_ = new QActionGroup(this);
  device_mouse_ = device->addAction("&Mouse", this, [this] { studio_.use_device(DeviceKind::Mouse); });
  device_phantom_ = device->addAction("&Phantom", this, [this] { studio_.use_device(DeviceKind::Phantom, phantom_options_); });
  device_none_ = device->addAction("&None", this, [this] { studio_.use_device(DeviceKind::None); });
  for (QAction* a : {device_mouse_, device_phantom_, device_none_}) {
    a->setCheckable(true);
    device_group_->addAction(a);
  }
  device->addSeparator();
  device->addAction("Fit the workspace to the &garments", this,
                    [this] { studio_.fit_workspace(false, viewport_->camera().orientation()); });
  device->addAction("Fit the workspace to the &body", this,
                    [this] { studio_.fit_workspace(true, viewport_->camera().orientation()); });
  device->addAction("Phantom &settings...", this, &MainWindow::phantom_settings_dialog);

  QMenu* help = menuBar()->addMenu("&Help");
  help->addAction("&Plugins", this, [this] {
    QString text;
    for (const std::string& id : studio_.tools().ids())
      text += QString("%1: %2\n").arg(QString::fromStdString(id), QString::fromStdString(studio_.tools().origin(id)));
    QMessageBox::information(this, "Tool plugins", text.isEmpty() ? "No tools were found." : text);
  });
  help->addAction("&About", this, [this] {
    QMessageBox::about(this, "Kiji Studio",
                       QString("Kiji Studio %1: interactive cloth design with a mouse or a Phantom.")
                           .arg(QString(kiji::version())));
  });
}

void MainWindow::set_edge_display(EdgeDisplay mode) {
  viewport_->set_edge_display(mode);
  for (QAction* a : edges_group_->actions()) a->setChecked(a->data().toInt() == int(mode));
}

void MainWindow::sync_device_menu() {
  const DeviceKind k = studio_.device_kind();
  device_mouse_->setChecked(k == DeviceKind::Mouse);
  device_phantom_->setChecked(k == DeviceKind::Phantom);
  device_none_->setChecked(k == DeviceKind::None);
}

void MainWindow::on_message(const QString& text, bool error) {
  statusBar()->showMessage(text, error ? 15000 : 5000);
  if (!error) return;
  errors_.push_back(text);
  std::fprintf(stderr, "kiji-studio: %s\n", text.toLocal8Bit().constData());
  // Not modal: the session goes on, and a scripted run is not held up. One box: a message that comes
  // while it is open replaces the one it shows, and says how many came.
  if (!error_box_) {
    error_box_ = new QMessageBox(QMessageBox::Warning, "Kiji Studio", text, QMessageBox::Ok, this);
    error_box_->setObjectName("error_box");
    error_box_->setAttribute(Qt::WA_DeleteOnClose);
    error_box_->setModal(false);
    errors_in_box_ = 0;
  }
  ++errors_in_box_;
  error_box_->setText(errors_in_box_ > 1 ? QString("%1\n\n(%2 messages; this is the latest)").arg(text).arg(errors_in_box_)
                                         : text);
  error_box_->show();
}

QString MainWindow::status_text() const {
  QStringList parts{status_sim_->text(), status_fps_->text(), status_haptic_->text(), status_vertices_->text(),
                    status_tool_->text()};
  if (!status_shared_->text().isEmpty()) parts << status_shared_->text();
  return parts.join(" | ");
}

void MainWindow::update_status() {
  const SimulationStats sim = studio_.loop().stats();
  const auto frame = studio_.frame();
  status_sim_->setText(QString("simulation %1 steps/s (%2 ms)%3")
                           .arg(sim.steps_per_second, 0, 'f', 0)
                           .arg(sim.step_ms, 0, 'f', 1)
                           .arg(frame && !frame->simulating ? ", paused" : (studio_.draping() ? ", draping" : "")));
  status_fps_->setText(QString("%1 frames/s").arg(viewport_->frames_per_second(), 0, 'f', 0));
  if (HapticLoop* h = studio_.haptics()) {
    const HapticStats st = h->stats();
    const qint64 now = QDateTime::currentMSecsSinceEpoch();
    double rate = st.rate_hz;
    if (last_haptic_time_ > 0 && now > last_haptic_time_ && st.ticks >= last_haptic_ticks_)
      rate = 1000.0 * double(st.ticks - last_haptic_ticks_) / double(now - last_haptic_time_);
    last_haptic_ticks_ = st.ticks;
    last_haptic_time_ = now;
    status_haptic_->setText(QString("%1 %2 Hz").arg(studio_.device_description()).arg(rate, 0, 'f', 0));
  } else {
    status_haptic_->setText("no device");
  }
  status_vertices_->setText(QString("%1 vertices").arg(frame ? frame->vertices : 0));
  const std::string tool = studio_.tool(kButtonPrimary);
  if (const auto peers = studio_.peer_view()) {
    int present = 0;
    for (const PeerRow& p : peers->peers) present += p.present;
    status_shared_->setText(!peers->joined ? QString("joining...")
                                           : QString("shared with %1 other%2").arg(present - 1).arg(present == 2 ? "" : "s"));
    // On the console too, so that a script running the app knows when it is in the shared session.
    if (peers->joined && !said_joined_) {
      std::printf("kiji-studio: in the shared session at step %llu\n", static_cast<unsigned long long>(peers->step));
      std::fflush(stdout);
    }
    said_joined_ = peers->joined;
  } else {
    said_joined_ = false;
    status_shared_->setText(studio_.shared() ? "sharing..." : "");
  }
  status_tool_->setText(QString("tool: %1").arg(tool.empty() ? "none" : QString::fromStdString(studio_.tools().info(tool).label)));
  // Undo and redo stay enabled: the frame says what was undoable a frame ago, and a shortcut
  // pressed meanwhile must not be lost; with nothing to undo, the status bar says so.
  if (frame && run_action_->isChecked() != frame->simulating) run_action_->setChecked(frame->simulating);
}

QImage MainWindow::grab_window() {
  // The view is a window of its own inside this one: QWidget::grab sees its place, not its pixels.
  QImage image = grab().toImage();
  const QImage view = viewport_->grabFramebuffer();
  QWidget* holder = viewport_->widget();
  QPainter painter(&image);
  painter.drawImage(QRect(holder->mapTo(this, QPoint(0, 0)), holder->size()), view);
  return image;
}

bool MainWindow::save_picture(const QString& path) {
  const QImage image = viewport_->grabFramebuffer();
  if (image.isNull() || !image.save(path)) {
    on_message("The picture was not saved to " + path + ": check the folder exists and the name ends in .png", true);
    return false;
  }
  on_message("Saved the picture " + path, false);
  return true;
}

void MainWindow::open_body_dialog() {
  const QString path = QFileDialog::getOpenFileName(
      this, "Open body", "/usr/share/assimp/models",
      "3D models (*.obj *.zae *.dae *.fbx *.glb *.gltf *.blend *.iqm *.ply *.stl *.3ds);;All files (*)");
  if (path.isEmpty()) return;
  QDialog d(this);
  d.setWindowTitle("Body import");
  auto* form = new QFormLayout(&d);
  auto* up = new QComboBox(&d);
  up->addItem("from the file");
  for (const char* a : {"+y", "-y", "+z", "-z", "+x", "-x"}) up->addItem(a);
  auto* front = new QComboBox(&d);
  front->addItem("from the file, else the feet");
  for (const char* a : {"+z", "-z", "+x", "-x", "+y", "-y"}) front->addItem(a);
  auto* smooth = new QCheckBox("round a low-poly body (Loop subdivision to 1 cm triangles)", &d);
  smooth->setChecked(true);
  auto* scale = number(&d, 1.0, 1e-6, 1e6, 6, " m a unit");
  auto* use_scale = new QCheckBox("override the file's", &d);
  auto* height = number(&d, 1.7, 0.01, 100, 3, " m");
  auto* use_height = new QCheckBox("scale to this height", &d);
  form->addRow("Up axis", up);
  form->addRow("Faces", front);
  form->addRow("", smooth);
  form->addRow("Scale", scale);
  form->addRow("", use_scale);
  form->addRow("Height", height);
  form->addRow("", use_height);
  auto* buttons = new QDialogButtonBox(QDialogButtonBox::Ok | QDialogButtonBox::Cancel, &d);
  form->addRow(buttons);
  connect(buttons, &QDialogButtonBox::accepted, &d, &QDialog::accept);
  connect(buttons, &QDialogButtonBox::rejected, &d, &QDialog::reject);
  if (d.exec() != QDialog::Accepted) return;
  BodyImportOptions o;  // as --body and `kiji drape` read one
  o.find_front = true;
  if (up->currentIndex() > 0) o.up = parse_axis(up->currentText().toStdString());
  if (front->currentIndex() > 0) o.front = parse_axis(front->currentText().toStdString());
  o.smooth = smooth->isChecked();
  if (use_scale->isChecked()) o.scale = scale->value();
  if (use_height->isChecked()) o.height = height->value();
  QApplication::setOverrideCursor(Qt::WaitCursor);
  studio_.open_body(path, o);
  QApplication::restoreOverrideCursor();
}

void MainWindow::new_garment_dialog() {
  QDialog d(this);
  d.setWindowTitle("New garment");
  auto* form = new QFormLayout(&d);
  auto* kind = new QComboBox(&d);
  kind->addItems({"rectangle", "panel"});
  auto* width = number(&d, 1.0, 0.01, 20, 3, " m");
  auto* h = number(&d, 1.0, 0.01, 20, 3, " m");
  auto* outline = new QLineEdit("0,0; 0.6,0; 0.5,0.8; 0.1,0.8", &d);
  outline->setToolTip("The panel's corners in metres, 'x, y' separated by ';'");
  auto* spacing = number(&d, 0.02, 0.001, 1, 4, " m");
  spacing->setToolTip("Distance between vertices: 0.02 m makes about 2,500 vertices a square metre");
  auto* material = new QComboBox(&d);
  for (const std::string& m : Material::preset_names()) material->addItem(QString::fromStdString(m));
  form->addRow("Pattern", kind);
  form->addRow("Width", width);
  form->addRow("Height", h);
  form->addRow("Outline", outline);
  form->addRow("Vertex spacing", spacing);
  form->addRow("Material", material);
  auto* buttons = new QDialogButtonBox(QDialogButtonBox::Ok | QDialogButtonBox::Cancel, &d);
  form->addRow(buttons);
  connect(buttons, &QDialogButtonBox::accepted, &d, &QDialog::accept);
  connect(buttons, &QDialogButtonBox::rejected, &d, &QDialog::reject);
  if (d.exec() != QDialog::Accepted) return;
  GarmentSpec g;
  g.kind = kind->currentIndex() == 0 ? GarmentSpec::Kind::Rectangle : GarmentSpec::Kind::Panel;
  g.width = width->value();
  g.height = h->value();
  g.spacing = spacing->value();
  g.material = material->currentText().toStdString();
  if (g.kind == GarmentSpec::Kind::Panel) {
    try {
      g.outline = parse_outline(outline->text());
    } catch (const std::exception& e) {
      on_message(QString("The garment was not made: ") + e.what(), true);
      return;
    }
  }
  studio_.add_garment(g);
}

void MainWindow::phantom_settings_dialog() {
  QDialog d(this);
  d.setWindowTitle("Phantom settings");
  auto* form = new QFormLayout(&d);
  auto* library = new QLineEdit(QString::fromStdString(phantom_options_.library), &d);
  library->setPlaceholderText("$KIJI_HD_LIBRARY, else libHD.so on the library path");
  auto* name = new QLineEdit(QString::fromStdString(phantom_options_.device_name), &d);
  name->setPlaceholderText("HD_DEFAULT_DEVICE (or \"Default Device\", \"Default PHANToM\")");
  auto* swap = new QCheckBox("swap the stylus's two buttons", &d);
  swap->setChecked(phantom_options_.swap_buttons);
  auto* gain = number(&d, studio_.haptic_options().force_gain, 0, 10, 2, "");
  gain->setToolTip("The tools' forces are multiplied by this before they are clamped to the device's maximum");
  form->addRow("HD library", library);
  form->addRow("Device name", name);
  form->addRow("", swap);
  form->addRow("Force gain", gain);
  if (PhantomDevice* p = studio_.phantom()) {
    const PhantomInfo& i = p->info();
    form->addRow("Device", new QLabel(QString("%1, %2 N continuous, %3 N/m, calibration %4")
                                          .arg(QString::fromStdString(i.model))
                                          .arg(i.max_continuous_force)
                                          .arg(i.max_stiffness)
                                          .arg(QString::fromStdString(i.calibration)),
                                      &d));
  }
  auto* buttons = new QDialogButtonBox(QDialogButtonBox::Ok | QDialogButtonBox::Cancel, &d);
  form->addRow(buttons);
  connect(buttons, &QDialogButtonBox::accepted, &d, &QDialog::accept);
  connect(buttons, &QDialogButtonBox::rejected, &d, &QDialog::reject);
  if (d.exec() != QDialog::Accepted) return;
  phantom_options_.library = library->text().trimmed().toStdString();
  phantom_options_.device_name = name->text().trimmed().toStdString();
  phantom_options_.swap_buttons = swap->isChecked();
  studio_.set_force_gain(gain->value());
  if (studio_.device_kind() == DeviceKind::Phantom) studio_.use_device(DeviceKind::Phantom, phantom_options_);
}

}  // namespace kiji::studio

namespace kiji::studio {

void MainWindow::share_dialog(bool host) {
  QDialog d(this);
  d.setWindowTitle(host ? "Host session" : "Join session");
  auto* form = new QFormLayout(&d);
  const PeerSettings defaults;
  auto* url = new QLineEdit(QString::fromStdString(defaults.url), &d);
  url->setToolTip("The LCM network: ttl=0 keeps it on this computer, ttl=1 reaches the local network");
  auto* channel = new QLineEdit(QString::fromStdString(defaults.channel), &d);
  QString user = qEnvironmentVariable("USER");
  auto* name = new QLineEdit(user.isEmpty() ? (host ? "host" : "peer") : user, &d);
  name->setToolTip("Your name as the others see it, beside your pointer");
  auto* key = new QLineEdit(&d);
  key->setPlaceholderText(host ? "empty: a new key file is made" : "the key file the host gave you");
  key->setToolTip(host ? "The session's shared secret; a file that does not exist is made (readable by you only): "
                         "give it to those who join"
                       : "The host's key file: only those who have it can join");
  // Named for scripts and tests that fill the dialog.
  url->setObjectName("url");
  channel->setObjectName("channel");
  name->setObjectName("name");
  key->setObjectName("key_file");
  auto* browse = new QPushButton("Browse...", &d);
  connect(browse, &QPushButton::clicked, &d, [&] {
    const QString path = host ? QFileDialog::getSaveFileName(&d, "Key file", {}, "Keys (*.key);;All files (*)",
                                                             nullptr, QFileDialog::DontConfirmOverwrite)
                              : QFileDialog::getOpenFileName(&d, "Key file", {}, "Keys (*.key);;All files (*)");
    if (!path.isEmpty()) key->setText(path);
  });
  auto* key_row = new QHBoxLayout;
  key_row->addWidget(key);
  key_row->addWidget(browse);
  form->addRow("Network (URL)", url);
  form->addRow("Channel", channel);
  form->addRow("Your name", name);
  form->addRow("Key file", key_row);
  auto* buttons = new QDialogButtonBox(QDialogButtonBox::Ok | QDialogButtonBox::Cancel, &d);
  buttons->button(QDialogButtonBox::Ok)->setText(host ? "Host" : "Join");
  form->addRow(buttons);
  connect(buttons, &QDialogButtonBox::accepted, &d, [&] {
    if (!host && key->text().trimmed().isEmpty()) {
      QMessageBox::warning(&d, "Join session", "Give the key file of the session (the host has it).");
      return;
    }
    d.accept();
  });
  connect(buttons, &QDialogButtonBox::rejected, &d, &QDialog::reject);
  if (d.exec() != QDialog::Accepted) return;
  PeerSettings settings;
  settings.host = host;
  settings.url = url->text().trimmed().toStdString();
  settings.channel = channel->text().trimmed().toStdString();
  settings.name = name->text().trimmed().toStdString();
  settings.key_file = key->text().trimmed().toStdString();
  studio_.share_session(settings);
}

bool MainWindow::save_peers(const QString& path) {
  peers_->refresh();
  QJsonObject out;
  const auto view = studio_.peer_view();
  out["shared"] = studio_.shared();
  out["summary"] = peers_->summary();
  out["peers"] = peers_->rows();
  if (view) {
    out["joined"] = view->joined;
    out["converged"] = view->converged;
    out["step"] = double(view->step);
    out["state_hash"] = QString("%1").arg(view->state_hash, 16, 16, QChar('0'));
    // Where the others' pointers are in the viewport's picture, for a check of what it shows.
    QJsonArray pointers;
    const qreal dpr = viewport_->devicePixelRatio();
    for (const PeerRow& p : view->peers) {
      if (p.self || !p.present || !p.has_presence || p.presence.pointer == Vec3::Zero()) continue;
      const QPointF at = viewport_->project(p.presence.pointer) * dpr;
      pointers.append(QJsonObject{{"name", QString::fromStdString(p.name)},
                                  {"colour", QColor::fromRgbF(float(p.colour.x()), float(p.colour.y()), float(p.colour.z())).name()},
                                  {"x", at.x()},
                                  {"y", at.y()}});
    }
    out["pointers"] = pointers;
  }
  QFile file(path);
  if (!file.open(QIODevice::WriteOnly) || file.write(QJsonDocument(out).toJson()) < 0) {
    on_message("The peers were not written to " + path + ": check the folder exists", true);
    return false;
  }
  return true;
}

}  // namespace kiji::studio
