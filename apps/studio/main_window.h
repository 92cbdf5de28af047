// Kiji Studio's window: the viewport in the middle, the tools and their parameters on the left, the
// Python console below, the peers of a shared session on the right, the menus (File, Edit, View, Simulation, Device, Help) and a status bar
// with the simulation's steps a second, the frames a second, the haptic loop's rate, the vertices
// and the active tool.
#pragma once

#include "studio.h"
#include "viewport.h"

#include <QMainWindow>
#include <QPointer>

class QAction;
class QActionGroup;
class QDockWidget;
class QLabel;
class QMessageBox;

namespace kiji::studio {

class PeersPanel;
class PythonConsole;
class ToolPanel;

class MainWindow : public QMainWindow {
  Q_OBJECT
 public:
  explicit MainWindow(Studio& studio, QWidget* parent = nullptr);
  ~MainWindow() override;

  Viewport& viewport() { return *viewport_; }
  ToolPanel& tool_panel() { return *tools_; }
  PythonConsole& console() { return *console_; }
  PeersPanel& peers_panel() { return *peers_; }
  // A shared session as the window shows it, as JSON: the Peers list's rows, the state hash, and
  // where each other peer's pointer is seen in the viewport (pixels of save_picture's image).
  bool save_peers(const QString& path);
  // The messages shown so far, errors among them (for tests and for the scripted runs' exit code).
  const QStringList& errors() const { return errors_; }
  QString status_text() const;
  // The viewport as a picture (what File > Save picture writes).
  bool save_picture(const QString& path);
  // The whole window, the view in it.
  QImage grab_window();
  void set_edge_display(EdgeDisplay mode);
  // Offers to recover the sessions an earlier run left unsaved when it did not quit cleanly (its
  // autosaves): recover the newest, discard them, or keep them for later. Returns whether one was
  // recovered.
  bool offer_recovery();
  // Asks whether to save a modified session before it is closed: true to go on (saved, or changes
  // let go), false to stay.
  bool maybe_save();
  // Saves to the session's file, or asks for one (false if not saved).
  bool save();
  bool save_as();
  // Removes the piece of cloth selected in the view (Ctrl + click), undoably.
  void delete_selected_piece();

 protected:
  void closeEvent(QCloseEvent* e) override;

 private:
  void build_menus();
  void update_status();
  void on_message(const QString& text, bool error);
  void open_body_dialog();
  void new_garment_dialog();
  void phantom_settings_dialog();
  void share_dialog(bool host);
  void sync_device_menu();
  void update_title();
  // Undo and redo go to the text field that has the keyboard, else to the scene.
  void undo_or_redo(bool redo);

  Studio& studio_;
  Viewport* viewport_;
  ToolPanel* tools_;
  PythonConsole* console_;
  PeersPanel* peers_;
  QDockWidget* peers_dock_;
  QAction* leave_action_;
  QDockWidget* tools_dock_;
  QDockWidget* console_dock_;
  QLabel* status_sim_;
  QLabel* status_fps_;
  QLabel* status_haptic_;
  QLabel* status_vertices_;
  QLabel* status_tool_;
  QLabel* status_shared_;
  QLabel* status_hint_;
  // A QPointer, not a pointer cleared by the box's destroyed signal: the box is a child, deleted
  // after the window's own destructor has run, where a slot of the window may not run.
  QPointer<QMessageBox> error_box_;
  int errors_in_box_ = 0;
  QAction* run_action_;
  QAction* undo_action_;
  QAction* redo_action_;
  QActionGroup* edges_group_;
  QActionGroup* device_group_;
  QAction* device_none_;
  QAction* device_mouse_;
  QAction* device_phantom_;
  PhantomOptions phantom_options_;
  QStringList errors_;
  std::uint64_t last_haptic_ticks_ = 0;
  bool said_joined_ = false;  // the console line for a shared session joined is written once a join
  qint64 last_haptic_time_ = 0;
};

}  // namespace kiji::studio
