// The desktop app's model, without widgets: the session and its simulation thread, the pointing
// device and its haptic loop, and every command of the menus. Each change to the session is one of
// its operations (kiji/operation.h), so undo, saving and replay see all of it. A command that fails
// says why through message() and leaves the session as it was.
#pragma once

#include "mouse_device.h"
#include "peer_link.h"
#include "scene_setup.h"

#include "kiji/operation.h"
#include "kiji/phantom.h"
#include "kiji/plugin_loader.h"
#include "kiji/simulation_loop.h"

#include <QElapsedTimer>
#include <QObject>
#include <QString>
#include <QStringList>
#include <QTimer>

#include <atomic>
#include <memory>

class QLockFile;

namespace kiji {
class Autosave;
}

namespace kiji::studio {

enum class DeviceKind { None, Mouse, Phantom };
QString device_kind_name(DeviceKind kind);

class Studio : public QObject {
  Q_OBJECT
 public:
  // clock_running: whether the session's clock runs from the start (see set_clock_running). An app
  // that sets a scene up first starts with it held, so that no step comes before its first operation.
  explicit Studio(std::shared_ptr<ToolRegistry> tools, bool clock_running = true, QObject* parent = nullptr);
  ~Studio() override;

  std::shared_ptr<Session> session() const { return session_; }
  SimulationLoop& loop() { return *loop_; }
  std::shared_ptr<const SceneFrame> frame() const { return loop_->frame(); }
  ToolRegistry& tools() { return *tools_; }

  // --- File ---
  // An empty scene: no body, no garment.
  void new_scene();
  bool open_body(const QString& path, const BodyImportOptions& options);
  bool add_garment(const GarmentSpec& spec);
  // A session file (.kiji: the log of every operation, and the state when it was saved) opened into
  // a new session: from the state it carries, without replaying its steps (a file saved by an
  // earlier Kiji, which carries none, is replayed).
  bool open_session(const QString& path);
  // Saves the session (with the history it was opened from) to a session file; it is then the
  // session's file, and the session is unmodified.
  bool save_session(const QString& path);
  // The session file the session was opened from or last saved to ("" if none).
  const QString& file() const { return file_; }
  // Whether the session changed (a stroke, a garment or body, an undo, a drape) since it was opened,
  // saved or made.
  bool modified() const { return changes_.load() != saved_changes_; }

  // --- Autosave and recovery (the library's Autosave, kiji/session_file.h) ---
  // The folder autosaves go to ("": none). Each session is autosaved there as it changes, from the
  // state it started with; the file is removed when the session is closed or the app quits cleanly.
  void set_autosave_folder(const QString& folder);
  QString autosave_path() const { return autosave_path_; }
  // Autosaves that an earlier run of the app left behind (it did not quit cleanly), newest first.
  QStringList unfinished_autosaves() const;
  // Rebuilds the session an autosave holds and makes it this one; the autosave is then removed.
  bool recover(const QString& autosave);
  // Removes an autosave that is not wanted.
  void discard_autosave(const QString& autosave);
  bool export_garment(const QString& path, int garment = 0);
  // Replays a journal file: the strokes of a version 1 journal on the scene as it is, at their times
  // (from the clock on); the operations of a version 2 one, which hold the whole scene, into a new
  // session that takes the place of this one (as open_session), so that the design is the journal's
  // whatever this scene's clock has done.
  bool replay(const QString& journal);
  // The session's operations as a readable JSON journal (version 2).
  bool save_journal(const QString& path);

  // --- Edit ---
  void undo();
  void redo();
  // Sews two stretches of border of a garment (mesh vertices, in order: the first of each meet, and
  // so on) with the sew tool, as one stroke: the first side traced with the primary button, the
  // second with the secondary.
  bool sew_seam(int garment, const std::vector<std::uint32_t>& first, const std::vector<std::uint32_t>& second);
  // Removes the piece of cloth that a vertex belongs to (the whole garment if it is one piece): an
  // edit of the undo history.
  bool remove_piece(int garment, std::uint32_t vertex);

  // --- Simulation ---
  void set_simulating(bool on);
  bool simulating() const;
  // Lets the garments fall and settle on the body for `seconds` of simulated time, with the drape's
  // finer solver settings, as fast as the machine goes (Session::drape): a new garment coarse first
  // when `coarse`, as one change; otherwise stepped by the session, frames showing it fall.
  void drape(double seconds, bool coarse = true);
  bool draping() const { return draping_.load(); }
  void cancel_drape() { cancel_drape_ = true; }
  // The scene as it was just before the first stroke (its operations before it replayed into a
  // new session); the strokes are dropped.
  bool reset();
  // Whether the session's clock runs (see SimulationLoop::set_stepping): held while a scripted
  // run sets its scene up and replays, so that it starts from time zero every time.
  void set_clock_running(bool on);

  // --- Tools ---
  // The tool the pointer's button uses (kButtonPrimary or kButtonSecondary) and its parameters.
  void set_tool(std::uint32_t button, const std::string& id, const ParamSet& params);
  std::string tool(std::uint32_t button) const { return button == kButtonSecondary ? secondary_.id : primary_.id; }
  const ParamSet& tool_params(std::uint32_t button) const {
    return button == kButtonSecondary ? secondary_.params : primary_.params;
  }
  // While the app picks with the pointer itself (a seam's borders), the device's buttons make no
  // strokes.
  void set_picking(bool on);
  bool picking() const { return picking_; }

  // --- Devices ---
  // Switches the pointing device. A Phantom that cannot be opened or started is a message (with the
  // HD error) and the mouse takes its place: returns false then.
  bool use_device(DeviceKind kind, const PhantomOptions& options = {});
  DeviceKind device_kind() const { return kind_; }
  MouseDevice* mouse() { return kind_ == DeviceKind::Mouse ? mouse_.get() : nullptr; }
  PhantomDevice* phantom() { return phantom_.get(); }
  HapticLoop* haptics() { return haptics_.get(); }
  const HapticOptions& haptic_options() const { return haptic_options_; }
  void set_force_gain(double gain);
  // The Phantom's workspace made to span the garments (or the body), turned with the camera.
  bool fit_workspace(bool to_body, const Eigen::Quaterniond& camera);
  QString device_description() const;

  // --- Sharing (File > Host session, Join session, Leave session) ---
  // Shares the session with peers over LCM: hosting makes this session the shared one; joining
  // replaces it by the host's when its snapshot arrives. A bad key file or a network that cannot
  // be opened is a message, and the session goes on unshared: returns false then. Sharing again
  // leaves the last shared session first.
  bool share_session(const PeerSettings& settings);
  void leave_session();
  bool shared() const { return static_cast<bool>(peer_); }
  // What the Peers list and the viewport show, as last copied (null when not shared).
  std::shared_ptr<const PeerView> peer_view() const { return peer_ ? peer_->view() : nullptr; }
  // Where this user looks from, sent to the peers with the pointer (the viewport says, as it draws).
  void set_viewpoint(const Vec3& eye, const Vec3& target);

 signals:
  // For the status bar (information) or a message box (errors).
  void message(const QString& text, bool error);
  // The session object changed (opened, reset, new): whoever holds it takes the new one.
  void session_replaced();
  void device_changed();
  // The scene changed size (a body or garment came or went): a viewport may frame it.
  void scene_changed();
  // Sharing started or ended, or the peers' view was copied afresh.
  void sharing_changed();
  void peers_changed();
  // The session's file or whether it is modified changed (the window's title says both).
  void file_changed();

 private:
  struct ToolChoice {
    std::string id;
    ParamSet params;
  };
  // Makes `session` the app's (its autosave started, `history` the operations before its state);
  // `file` is the session file it came from, or "".
  void replace_session(std::shared_ptr<Session> session, const QString& file = {}, std::vector<Operation> history = {},
                       bool modified = false);
  void start_loop();
  void start_autosave(bool with_state);
  void file_changed_now();
  void stop_autosave(bool remove_file);
  void watch_changes();
  void stop_device();
  void poll();
  void poll_peers();
  bool fail(const QString& what, const std::exception& e);

  std::shared_ptr<ToolRegistry> tools_;
  std::shared_ptr<Session> session_;
  std::unique_ptr<SimulationLoop> loop_;
  ToolChoice primary_, secondary_;

  DeviceKind kind_ = DeviceKind::None;
  std::unique_ptr<MouseDevice> mouse_;
  std::unique_ptr<PhantomDevice> phantom_;
  std::unique_ptr<HapticLoop> haptics_;
  HapticOptions haptic_options_;
  std::size_t reported_haptic_errors_ = 0;
  bool reported_servo_stop_ = false;

  bool clock_running_ = true;
  std::atomic<bool> draping_{false}, cancel_drape_{false};
  QTimer poll_timer_;

  bool picking_ = false;

  QString file_;
  std::vector<Operation> history_;  // the operations before the state the session was opened from
  std::atomic<std::uint64_t> changes_{0};
  std::uint64_t saved_changes_ = 0;
  bool said_modified_ = false;
  int change_listener_ = -1;
  QString autosave_folder_, autosave_path_;
  std::unique_ptr<Autosave> autosave_;
  std::unique_ptr<QLockFile> autosave_lock_;
  static constexpr qint64 kCheckpointEveryMs = 30000;
  QElapsedTimer checkpoint_clock_;
  std::uint64_t checkpoint_changes_ = 0;
  bool was_draping_ = false;

  std::unique_ptr<PeerLink> peer_;
  QTimer peer_timer_;
  int peer_ticks_ = 0;
  Vec3 eye_{0, 0, 0}, target_{0, 0, 0};
};

}  // namespace kiji::studio
