#include "studio.h"

#include "kiji/io.h"
#include "kiji/journal_file.h"
#include "kiji/session.h"
#include "kiji/session_file.h"
#include "kiji/topology.h"

#include <QCoreApplication>
#include <QDateTime>
#include <QDir>
#include <QFile>
#include <QFileInfo>
#include <QLockFile>
#include <QStandardPaths>

#include <set>

namespace kiji::studio {

QString device_kind_name(DeviceKind kind) {
  switch (kind) {
    case DeviceKind::None: return "none";
    case DeviceKind::Mouse: return "mouse";
    case DeviceKind::Phantom: return "phantom";
  }
  return "none";
}

namespace {

// Whether an operation is a change the user would want saved: not pausing, time passing or the
// moves of a stroke (its end is).
bool is_change(const Operation& op) {
  if (const auto* t = std::get_if<op::ToolInput>(&op.data))
    return t->event.phase == Phase::End || t->event.phase == Phase::Cancel;
  return !std::holds_alternative<op::SetSimulating>(op.data) && !std::holds_alternative<op::Advance>(op.data) &&
         !std::holds_alternative<op::SetFrameRate>(op.data) && !std::holds_alternative<op::SetPickRadius>(op.data) &&
         !std::holds_alternative<op::Checkpoint>(op.data);
}

// A point just inside a face of v, near v: a pick there finds v's side of the cloth, not the side of
// a vertex that a cut left at the same place.
Vec3 inside_near(const Garment& g, Vertex v) {
  const Mesh& m = g.mesh();
  for (Face f : CGAL::faces_around_target(m.halfedge(v), m)) {
    if (f == Mesh::null_face()) continue;
    Vec3 c = Vec3::Zero();
    for (Vertex w : CGAL::vertices_around_face(m.halfedge(f), m)) c += g.position(w) / 3.0;
    return g.position(v) + 0.05 * (c - g.position(v));
  }
  return g.position(v);
}

}  // namespace

Studio::Studio(std::shared_ptr<ToolRegistry> tools, bool clock_running, QObject* parent)
    : QObject(parent), tools_(std::move(tools)), clock_running_(clock_running) {
  session_ = std::make_shared<Session>(tools_);
  watch_changes();
  start_loop();
  connect(&poll_timer_, &QTimer::timeout, this, &Studio::poll);
  poll_timer_.start(100);
  connect(&peer_timer_, &QTimer::timeout, this, &Studio::poll_peers);
}

Studio::~Studio() {
  poll_timer_.stop();
  peer_timer_.stop();
  peer_.reset();
  cancel_drape_ = true;
  loop_->attach(nullptr);
  stop_device();
  loop_->stop();
  // A clean quit: nothing to recover.
  stop_autosave(/*remove_file=*/true);
  session_->remove_listener(change_listener_);
}

bool Studio::fail(const QString& what, const std::exception& e) {
  emit message(what + ": " + QString::fromStdString(e.what()), true);
  return false;
}

void Studio::start_loop() {
  loop_ = std::make_unique<SimulationLoop>(session_, 60);
  loop_->set_stepping(clock_running_);
  if (!primary_.id.empty() && !picking_) loop_->set_tool(kButtonPrimary, primary_.id, primary_.params);
  if (!secondary_.id.empty() && !picking_) loop_->set_tool(kButtonSecondary, secondary_.id, secondary_.params);
  loop_->start();
  loop_->attach(haptics_.get());
}

void Studio::watch_changes() {
  // On the thread that applies the operation: only an atomic count here.
  change_listener_ = session_->add_listener([this](const Operation& op) {
    if (is_change(op)) changes_.fetch_add(1);
  });
}

void Studio::replace_session(std::shared_ptr<Session> session, const QString& file, std::vector<Operation> history,
                             bool modified) {
  if (peer_) {
    leave_session();
    emit message("Left the shared session: the new scene is yours alone (host or join again to share it)", false);
  }
  cancel_drape_ = true;
  loop_->attach(nullptr);  // the haptic loop lets go of the old session's tools
  loop_->stop();
  loop_.reset();
  // The session closed is saved or was let go on purpose: its autosave goes with it.
  stop_autosave(/*remove_file=*/true);
  session_->remove_listener(change_listener_);
  session_ = std::move(session);
  file_ = file;
  history_ = std::move(history);
  changes_ = 0;
  saved_changes_ = modified ? ~std::uint64_t(0) : 0;
  watch_changes();
  start_autosave(/*with_state=*/true);
  cancel_drape_ = false;
  start_loop();
  emit session_replaced();
  emit scene_changed();
  file_changed_now();
}

void Studio::new_scene() {
  replace_session(std::make_shared<Session>(tools_));
  emit message("New scene", false);
}

void Studio::set_autosave_folder(const QString& folder) {
  if (folder == autosave_folder_ && (autosave_ || folder.isEmpty())) return;
  auto stop_and_start = [&] {
    stop_autosave(/*remove_file=*/true);
    autosave_folder_ = folder;
    start_autosave(/*with_state=*/true);
  };
  if (loop_ && loop_->running()) {
    try {
      loop_->call([&](Session&) { stop_and_start(); });
    } catch (const std::exception& e) {
      fail("Autosave is off", e);
    }
  } else {
    stop_and_start();
  }
}

void Studio::start_autosave(bool with_state) {
  if (autosave_folder_.isEmpty()) return;
  if (!QDir().mkpath(autosave_folder_)) {
    emit message("Autosave is off: the folder " + autosave_folder_ + " cannot be made", true);
    return;
  }
  static int counter = 0;
  const QString path = QDir(autosave_folder_)
                           .filePath(QString("session-%1-%2.kiji").arg(QCoreApplication::applicationPid()).arg(++counter));
  auto lock = std::make_unique<QLockFile>(path + ".lock");
  lock->setStaleLockTime(0);
  if (!lock->tryLock(0)) {
    emit message("Autosave is off: " + path + " is in use", true);
    return;
  }
  try {
    QFile::remove(path);
    autosave_ = std::make_unique<Autosave>(*session_, path.toStdString());
    // The session's state as it starts: recovery begins there.
    if (with_state && (session_->garment_count() > 0 || session_->body())) autosave_->write_state();
  } catch (const std::exception& e) {
    autosave_.reset();
    fail("Autosave is off", e);
    return;
  }
  autosave_path_ = path;
  autosave_lock_ = std::move(lock);
  checkpoint_changes_ = changes_.load();
  checkpoint_clock_.restart();
}

void Studio::stop_autosave(bool remove_file) {
  autosave_.reset();
  if (remove_file && !autosave_path_.isEmpty()) QFile::remove(autosave_path_);
  autosave_lock_.reset();  // unlocks, removing the lock file
  autosave_path_.clear();
}

QStringList Studio::unfinished_autosaves() const {
  QStringList out;
  if (autosave_folder_.isEmpty()) return out;
  QDir dir(autosave_folder_);
  for (const QFileInfo& f : dir.entryInfoList({"session-*.kiji"}, QDir::Files, QDir::Time)) {
    if (f.absoluteFilePath() == QFileInfo(autosave_path_).absoluteFilePath()) continue;
    // Locked by a running app (this one or another): its own. Otherwise its app has gone.
    QLockFile lock(f.absoluteFilePath() + ".lock");
    lock.setStaleLockTime(0);
    if (!lock.tryLock(0)) continue;
    lock.unlock();
    if (f.size() > 0) out << f.absoluteFilePath();
    else QFile::remove(f.absoluteFilePath());
  }
  return out;
}

bool Studio::recover(const QString& autosave) {
  std::shared_ptr<Session> session;
  Recovered r;
  try {
    r = kiji::recover(autosave.toStdString(), tools_, /*keep_saving=*/false);
    session = std::move(r.session);
  } catch (const std::exception& e) {
    return fail("The session in " + autosave + " was not recovered (the file is kept)", e);
  }
  replace_session(std::move(session), {}, {}, /*modified=*/true);
  discard_autosave(autosave);
  QString text = QString("Recovered the session of %1 (%2 operations)")
                     .arg(QFileInfo(autosave).lastModified().toString("yyyy-MM-dd hh:mm"))
                     .arg(r.report.operations);
  if (r.cancelled_strokes) text += QString("; %1 unfinished stroke(s) cancelled").arg(r.cancelled_strokes);
  if (!r.report.damage.empty()) text += "; its damaged end was left out (" + QString::fromStdString(r.report.damage) + ")";
  emit message(text + ". Save it to keep it.", false);
  return true;
}

void Studio::discard_autosave(const QString& autosave) {
  QFile::remove(autosave);
  QFile::remove(autosave + ".lock");
}

bool Studio::open_body(const QString& path, const BodyImportOptions& options) {
  const std::string file = QFileInfo(path).absoluteFilePath().toStdString();
  std::optional<Body> body;
  try {
    body = Body::load(file, options);  // seconds for a large file: outside the session's lock
  } catch (const std::exception& e) {
    return fail("The body was not opened", e);
  }
  try {
    loop_->call([&](Session& s) {
      s.set_body(*body);
      // Garments not yet touched are laid over the new body.
      if (!has_strokes(s) && !s.stroke_active()) lay_over_body(s);
    });
  } catch (const std::exception& e) {
    return fail("The body was not set", e);
  }
  emit message(QString("Body %1: %2 triangles, %3 m tall (%4)")
                   .arg(QFileInfo(path).fileName())
                   .arg(body->triangles().size())
                   .arg(body->height(), 0, 'f', 2)
                   .arg(QString::fromStdString(body->report().format)),
               false);
  emit scene_changed();
  return true;
}

bool Studio::add_garment(const GarmentSpec& spec) {
  try {
    loop_->call([&](Session& s) { studio::add_garment(s, spec); });
  } catch (const std::exception& e) {
    return fail("The garment was not made", e);
  }
  emit message(QString("New garment: %1").arg(QString::fromStdString(spec.describe())), false);
  emit scene_changed();
  return true;
}

bool Studio::open_session(const QString& path) {
  auto session = std::make_shared<Session>(tools_);
  std::size_t operations = 0;
  std::vector<Operation> ops;
  SavedState state;
  try {
    SessionFileReport report;
    ops = load_session(path.toStdString(), &report, &state);
    // From the state the file carries: the steps before it are its history, not replayed.
    std::lock_guard<std::recursive_mutex> lock(session->mutex());
    operations = open_operations(*session, ops, state);
    if (!report.damage.empty())
      emit message(QString("%1 was damaged at its end (%2): the %3 operations before it were opened")
                       .arg(path, QString::fromStdString(report.damage))
                       .arg(report.operations),
                   true);
  } catch (const std::exception& e) {
    return fail("The session was not opened (the one open is as it was)", e);
  }
  ops.resize(state.found ? state.after : 0);
  replace_session(std::move(session), QFileInfo(path).absoluteFilePath(), std::move(ops));
  emit message(state.found ? QString("Opened %1 from the state it was saved in").arg(QFileInfo(path).fileName())
                           : QString("Opened %1: %2 operations replayed").arg(QFileInfo(path).fileName()).arg(operations),
               false);
  return true;
}

bool Studio::save_session(const QString& path) {
  std::uint64_t changes = 0;
  try {
    loop_->call([&](Session& s) {
      kiji::save_session(s, path.toStdString(), history_);
      changes = changes_.load();
    });
  } catch (const std::exception& e) {
    return fail("The session was not saved", e);
  }
  file_ = QFileInfo(path).absoluteFilePath();
  saved_changes_ = changes;
  file_changed_now();
  emit message("Saved " + path, false);
  return true;
}

bool Studio::export_garment(const QString& path, int garment) {
  try {
    loop_->call([&](Session& s) { kiji::export_garment(s.garment(static_cast<std::size_t>(garment)), path.toStdString()); });
  } catch (const std::exception& e) {
    return fail("The garment was not exported", e);
  }
  emit message("Exported " + path, false);
  return true;
}

bool Studio::replay(const QString& journal) {
  JournalFile file;
  try {
    file = read_journal_file(journal.toStdString());
  } catch (const std::exception& e) {
    return fail("The journal was not replayed", e);
  }
  if (file.version >= 2) {
    auto session = std::make_shared<Session>(tools_);
    std::size_t done = 0;
    try {
      std::lock_guard<std::recursive_mutex> lock(session->mutex());
      done = kiji::replay(*session, file.operations);
    } catch (const std::exception& e) {
      return fail("The journal was not replayed (the scene is as it was)", e);
    }
    // A design not yet in a session file: closing it asks first.
    replace_session(std::move(session), {}, {}, /*modified=*/true);
    emit message(QString("Replayed %1 operations from %2").arg(done).arg(journal), false);
    return true;
  }
  try {
    std::size_t done = 0;
    loop_->call([&](Session& s) { done = kiji::replay(s, file.strokes); });
    emit message(QString("Replayed %1 strokes from %2").arg(done).arg(journal), false);
  } catch (const std::exception& e) {
    return fail("The journal was not replayed (what came before the failing entry stays)", e);
  }
  return true;
}

bool Studio::save_journal(const QString& path) {
  try {
    loop_->call([&](Session& s) { kiji::save_journal(s, path.toStdString()); });
  } catch (const std::exception& e) {
    return fail("The journal was not saved", e);
  }
  emit message("Saved the journal to " + path, false);
  return true;
}

void Studio::undo() {
  loop_->post([this](Session& s) {
    if (!s.undo()) QMetaObject::invokeMethod(this, [this] { emit message("Nothing to undo", false); });
  }, "undo");
}

void Studio::redo() {
  loop_->post([this](Session& s) {
    if (!s.redo()) QMetaObject::invokeMethod(this, [this] { emit message("Nothing to redo", false); });
  }, "redo");
}

bool Studio::sew_seam(int garment, const std::vector<std::uint32_t>& first, const std::vector<std::uint32_t>& second) {
  if (!tools_->has("sew")) {
    emit message("There is no sew tool (see Help > Plugins): the seam was not sewn", true);
    return false;
  }
  if (first.size() < 2 || second.size() < 2) {
    emit message("A seam needs two sides of at least two border vertices each", true);
    return false;
  }
  std::size_t pairs = 0;
  bool closing = false;
  try {
    loop_->call([&](Session& s) {
      if (garment < 0 || std::size_t(garment) >= s.garment_count())
        throw InputError("the garment picked is gone (it was removed meanwhile)");
      const Garment& g = s.garment(std::size_t(garment));
      Stroke stroke;
      auto trace = [&](const std::vector<std::uint32_t>& side, std::uint32_t button) {
        for (std::uint32_t v : side) {
          const Vertex vertex(v);
          if (v >= g.vertex_capacity() || g.mesh().is_removed(vertex))
            throw InputError("a border vertex picked is gone (the garment changed meanwhile): pick the sides again");
          ToolEvent e;
          e.phase = Phase::Move;
          e.time = s.time();
          e.position = inside_near(g, vertex);
          e.buttons = button;
          stroke.push_back(e);
        }
      };
      trace(first, kButtonPrimary);
      trace(second, kButtonSecondary);
      stroke.front().phase = Phase::Begin;
      stroke.back().phase = Phase::End;
      ParamSet params = s.params_for("sew", {{"mode", std::string("seam")}, {"join", std::string("closing")}});
      if (primary_.id == "sew") {
        params = primary_.params;
        params.set("mode", std::string("seam"));
      }
      s.run("sew", params, stroke);
      pairs = std::max(first.size(), second.size());
      closing = params.get_string("join") == "closing";
    });
  } catch (const std::exception& e) {
    return fail("The seam was not sewn (the garment is as it was)", e);
  }
  emit message(closing ? QString("Tacked: a seam of %1 pairs, sewn as the simulation draws it shut (Ctrl+Z takes it out)").arg(pairs)
                       : QString("Sewn: a seam of %1 pairs (Ctrl+Z takes it out)").arg(pairs),
               false);
  return true;
}

bool Studio::remove_piece(int garment, std::uint32_t vertex) {
  std::size_t faces = 0;
  bool whole = false;
  try {
    loop_->call([&](Session& s) {
      if (garment < 0 || std::size_t(garment) >= s.garment_count()) throw InputError("the garment picked is gone");
      Garment g = s.garment(std::size_t(garment));
      const Mesh& m = g.mesh();
      const Vertex start(vertex);
      if (vertex >= g.vertex_capacity() || m.is_removed(start) || m.is_isolated(start))
        throw InputError("the piece picked is gone (the garment changed meanwhile): pick it again");
      if (g.count_pieces() < 2) {
        whole = true;
        faces = m.number_of_faces();
        s.remove_garment(std::size_t(garment));
        return;
      }
      // The piece: faces reached from the vertex's across shared edges.
      std::set<Face> piece;
      std::vector<Face> stack;
      for (Face f : CGAL::faces_around_target(m.halfedge(start), m))
        if (f != Mesh::null_face() && piece.insert(f).second) stack.push_back(f);
      while (!stack.empty()) {
        const Face f = stack.back();
        stack.pop_back();
        for (Halfedge h : CGAL::halfedges_around_face(m.halfedge(f), m)) {
          const Face n = m.face(m.opposite(h));
          if (n != Mesh::null_face() && piece.insert(n).second) stack.push_back(n);
        }
      }
      std::vector<Edge> edges;
      for (Face f : piece)
        for (Halfedge h : CGAL::halfedges_around_face(m.halfedge(f), m)) edges.push_back(m.edge(h));
      std::sort(edges.begin(), edges.end());
      edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
      faces = piece.size();
      remove_edges(g, edges);
      s.set_garment(std::size_t(garment), g);
    });
  } catch (const std::exception& e) {
    return fail("The piece was not removed", e);
  }
  emit message(whole ? QString("Removed the garment (%1 faces; Ctrl+Z brings it back)").arg(faces)
                     : QString("Removed a piece of %1 faces (Ctrl+Z brings it back)").arg(faces),
               false);
  emit scene_changed();
  return true;
}

void Studio::set_picking(bool on) {
  if (picking_ == on) return;
  picking_ = on;
  loop_->set_tool(kButtonPrimary, on ? std::string() : primary_.id, primary_.params);
  loop_->set_tool(kButtonSecondary, on ? std::string() : secondary_.id, secondary_.params);
}

void Studio::set_simulating(bool on) {
  loop_->post([on](Session& s) { s.set_simulating(on); }, on ? "run" : "pause");
}

bool Studio::simulating() const {
  const auto f = loop_->frame();
  return f ? f->simulating : true;
}

void Studio::drape(double seconds, bool coarse) {
  if (peer_) {
    emit message("Draping is not shared with the peers: leave the session to drape, or let the shared clock run", true);
    return;
  }
  if (draping_.exchange(true)) return;
  cancel_drape_ = false;
  SimulationLoop* loop = loop_.get();
  loop->post([this, loop, seconds, coarse](Session& s) {
    struct Done {
      std::atomic<bool>& flag;
      ~Done() { flag = false; }
    } done{draping_};
    long step = 0;
    int shown = 0;
    // Where the garments are, as the user placed them (each new one is laid over the body). A new flat
    // garment falls as a coarse copy first (seconds, where the session's own steps take half a minute
    // at 14,000 vertices); the copy is not the session's garment, so the status line shows how far.
    const std::vector<DrapeResult> results = s.drape(seconds, [&](double fraction) {
      if (++step % 6 == 0) loop->publish_now();
      if (const int tenth = static_cast<int>(fraction * 10); tenth > shown) {
        shown = tenth;
        QMetaObject::invokeMethod(this, [this, tenth] {
          emit message(QString("Draping... %1 %").arg(tenth * 10), false);
        });
      }
      return !cancel_drape_.load() && !loop->stop_requested();
    }, /*place=*/false, 0.02, coarse);
    // Garments draped coarse first each took their own time; stepped, they were stepped together.
    double simulated = 0, wall = 0;
    std::size_t copied = 0;
    for (const DrapeResult& r : results) {
      simulated = std::max(simulated, r.seconds_simulated);
      copied += r.coarse_vertices;
      wall = r.coarse_vertices ? wall + r.wall_seconds : r.wall_seconds;
    }
    const bool paused = !s.simulating();
    QMetaObject::invokeMethod(this, [this, simulated, paused, copied, wall] {
      emit message(QString("Draped for %1 s of simulated time in %2 s%3%4")
                       .arg(simulated, 0, 'f', 2)
                       .arg(wall, 0, 'f', 1)
                       .arg(copied ? QString(" (a coarse copy of %1 vertices first)").arg(copied) : QString())
                       .arg(paused && !copied ? " (the simulation ran for it, and is paused again)" : ""),
                   false);
    });
  }, "drape");
}

bool Studio::reset() {
  auto session = std::make_shared<Session>(tools_);
  try {
    std::vector<Operation> setup;
    loop_->call([&](Session& s) {
      for (const Operation& op : s.journal().operations()) {
        if (std::holds_alternative<op::ToolInput>(op.data)) break;
        setup.push_back(op);
      }
    });
    std::lock_guard<std::recursive_mutex> lock(session->mutex());
    kiji::replay(*session, setup);
  } catch (const std::exception& e) {
    return fail("The scene was not reset", e);
  }
  replace_session(std::move(session), file_, history_, /*modified=*/true);
  emit message("Reset: the scene as it was before the first stroke", false);
  return true;
}

void Studio::set_clock_running(bool on) {
  clock_running_ = on;
  loop_->set_stepping(on);
}

void Studio::set_tool(std::uint32_t button, const std::string& id, const ParamSet& params) {
  (button == kButtonSecondary ? secondary_ : primary_) = ToolChoice{id, params};
  if (!picking_) loop_->set_tool(button, id, params);
}

void Studio::stop_device() {
  if (haptics_) haptics_->stop();
  haptics_.reset();
  phantom_.reset();  // stops its servo loop and disables it, in the vendor's order
  mouse_.reset();
}

bool Studio::use_device(DeviceKind kind, const PhantomOptions& options) {
  loop_->attach(nullptr);
  stop_device();
  kind_ = DeviceKind::None;
  reported_haptic_errors_ = 0;
  reported_servo_stop_ = false;
  bool ok = true;
  if (kind == DeviceKind::Phantom) {
    try {
      phantom_ = std::make_unique<PhantomDevice>(options);
      const auto f = loop_->frame();
      Box3 around = f ? f->bounds() : Box3();
      if (around.isEmpty()) around = Box3(Vec3(-0.5, 0.5, -0.5), Vec3(0.5, 1.5, 0.5));
      phantom_->set_mapping(WorkspaceMapping::fit(phantom_->workspace(), around));
      haptics_ = std::make_unique<HapticLoop>(*phantom_, haptic_options_);
      haptics_->start();
      kind_ = DeviceKind::Phantom;
      const PhantomInfo& i = phantom_->info();
      emit message(QString("Phantom: %1 from %2 (calibration %3, %4 N continuous)")
                       .arg(QString::fromStdString(i.model), QString::fromStdString(i.library),
                            QString::fromStdString(i.calibration))
                       .arg(i.max_continuous_force),
                   false);
    } catch (const std::exception& e) {
      haptics_.reset();
      phantom_.reset();
      emit message("The Phantom is not available, the mouse is used instead: " + QString::fromStdString(e.what()), true);
      kind = DeviceKind::Mouse;
      ok = false;
    }
  }
  if (kind == DeviceKind::Mouse) {
    mouse_ = std::make_unique<MouseDevice>();
    haptics_ = std::make_unique<HapticLoop>(*mouse_, haptic_options_);
    haptics_->start();
    kind_ = DeviceKind::Mouse;
  }
  loop_->attach(haptics_.get());
  emit device_changed();
  return ok;
}

void Studio::set_force_gain(double gain) {
  HapticOptions o = haptic_options_;
  o.force_gain = gain;
  try {
    o.validate();
  } catch (const std::exception& e) {
    fail("The force gain was not changed", e);
    return;
  }
  haptic_options_ = o;
  if (haptics_) haptics_->set_force_gain(gain);
}

bool Studio::fit_workspace(bool to_body, const Eigen::Quaterniond& camera) {
  if (!phantom_) {
    emit message("No Phantom is in use: choose it in the Device menu first", true);
    return false;
  }
  const auto f = loop_->frame();
  Box3 target;
  if (f && to_body && f->body) target = f->body->bounds();
  if (f && !to_body)
    for (const GarmentFrame& g : f->garments) target.extend(g.bounds);
  try {
    const WorkspaceMapping m = WorkspaceMapping::fit(phantom_->workspace(), target, camera);
    phantom_->set_mapping(m);
    emit message(QString("The Phantom's workspace spans the %1: %2 world metres a device metre")
                     .arg(to_body ? "body" : "garments")
                     .arg(m.scale, 0, 'f', 2),
                 false);
  } catch (const std::exception& e) {
    return fail("The workspace was not fitted", e);
  }
  return true;
}

QString Studio::device_description() const {
  switch (kind_) {
    case DeviceKind::None: return "no device";
    case DeviceKind::Mouse: return "mouse";
    case DeviceKind::Phantom: return QString::fromStdString(phantom_->name());
  }
  return {};
}

void Studio::file_changed_now() {
  said_modified_ = modified();
  emit file_changed();
}

void Studio::poll() {
  for (const std::string& m : loop_->take_messages()) emit message(QString::fromStdString(m), true);
  if (modified() != said_modified_) file_changed_now();
  // The autosave begins again from the state now and then (and after a drape, which is long to
  // simulate again), so that recovery replays only the last of the work.
  const std::uint64_t changes = changes_.load();
  const bool draped = was_draping_ && !draping_.load();
  was_draping_ = draping_.load();
  if (autosave_ && changes != checkpoint_changes_ && !draping_.load() &&
      (draped || checkpoint_clock_.elapsed() > kCheckpointEveryMs)) {
    checkpoint_changes_ = changes;
    checkpoint_clock_.restart();
    loop_->post([this](Session&) {
      if (autosave_) autosave_->write_state();
    }, "autosave");
  }
  if (haptics_) {
    const HapticStats st = haptics_->stats();
    const std::size_t errors = st.tool_errors + st.device_errors;
    if (errors > reported_haptic_errors_) {
      emit message(QString("The haptic loop sent zero force %1 times: %2")
                       .arg(errors - reported_haptic_errors_)
                       .arg(QString::fromStdString(st.last_error)),
                   true);
      reported_haptic_errors_ = errors;
    }
  }
  if (phantom_ && !reported_servo_stop_) {
    const PhantomStatus st = phantom_->status();
    if (st.servo_stopped_by_error) {
      reported_servo_stop_ = true;
      const QString why = QString::fromStdString(st.last_error_text);
      // Back to the mouse, with the reason said.
      use_device(DeviceKind::Mouse);
      emit message("The Phantom's servo loop stopped (" + why + "); the mouse is used instead", true);
    }
  }
}

}  // namespace kiji::studio

namespace kiji::studio {

bool Studio::share_session(const PeerSettings& settings) {
  if (peer_) leave_session();
  PeerSettings s = settings;
  if (s.host && s.key_file.empty())
    s.default_key_dir = QDir(QStandardPaths::writableLocation(QStandardPaths::AppDataLocation)).filePath("keys").toStdString();
  if (draping_.load()) {
    emit message("The session was not shared: a drape is running (stop it first)", true);
    return false;
  }
  try {
    peer_ = std::make_unique<PeerLink>(*session_, s);
  } catch (const std::exception& e) {
    return fail(QString("The session was not %1 (it goes on unshared)").arg(s.host ? "hosted" : "joined"), e);
  }
  const PeerSettings& used = peer_->settings();
  QString text = QString("%1 the session on %2, channel %3")
                     .arg(used.host ? "Hosting" : "Joining", QString::fromStdString(used.url),
                          QString::fromStdString(used.channel));
  if (peer_->made_key())
    text += QString("; new key file %1: give it to those who join").arg(QString::fromStdString(used.key_file));
  emit message(text, false);
  peer_ticks_ = 0;
  peer_timer_.start(50);  // presence at 20 Hz, the peers' list at 10 Hz
  poll_peers();
  emit sharing_changed();
  return true;
}

void Studio::leave_session() {
  if (!peer_) return;
  peer_timer_.stop();
  peer_.reset();  // says goodbye, and the session is this app's own again
  emit sharing_changed();
  emit peers_changed();
}

void Studio::set_viewpoint(const Vec3& eye, const Vec3& target) {
  eye_ = eye;
  target_ = target;
}

void Studio::poll_peers() {
  if (!peer_) return;
  const std::string failure = peer_->error();
  if (!failure.empty()) {
    leave_session();
    emit message("The shared session stopped (the session goes on unshared): " + QString::fromStdString(failure), true);
    return;
  }
  PeerPresence presence;
  presence.eye = eye_;
  presence.target = target_;
  if (const auto f = loop_->frame(); f && f->has_pointer) {
    presence.pointer = f->pointer.position;
    presence.orientation = f->pointer.orientation;
    presence.buttons = f->pointer.buttons;
    presence.tool = f->stroke_tool;
  }
  const bool sample = ++peer_ticks_ >= 2;
  // A busy session (a step, a stroke) is tried again at the next tick: the UI never waits for it.
  if (!peer_->update(&presence, sample)) return;
  if (sample) peer_ticks_ = 0;
  for (const std::string& why : peer_->take_refusals())
    emit message("Refused: " + QString::fromStdString(why) + " (the cloth is as it was)", false);
  if (sample) emit peers_changed();
}

}  // namespace kiji::studio
