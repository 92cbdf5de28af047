// kiji-studio: the desktop app. Parses the command line (a bad option is a message and exit 2 before
// any window opens), sets the scene up, and either runs for the user or, with --quit-after, for that
// long before writing what was asked and exiting (1 if any of it failed).
#include "benchmark.h"
#include "main_window.h"
#include "python_console.h"
#include "studio_options.h"
#include "tool_panel.h"

#include "kiji/version.h"

#include <QApplication>
#include <QDir>
#include <QEventLoop>
#include <QStandardPaths>
#include <QSurfaceFormat>
#include <QTimer>

#include <cstdio>

using namespace kiji;
using namespace kiji::studio;

namespace {

// The steps of a scripted run: each one that fails is said on stderr and makes the exit code 1.
struct Run {
  Studio& studio;
  MainWindow& window;
  const StudioOptions& o;
  int failures = 0;

  void check(bool ok, const char* what) {
    if (!ok) {
      ++failures;
      std::fprintf(stderr, "kiji-studio: %s failed\n", what);
    }
  }

  void set_up() {
    if (o.recover) {
      const QStringList left = studio.unfinished_autosaves();
      if (left.isEmpty()) std::fprintf(stderr, "kiji-studio: --recover: there is no session to recover\n");
      else check(studio.recover(left.front()), "--recover");
    }
    if (o.open_session) check(studio.open_session(QString::fromStdString(*o.open_session)), "--open");
    if (o.body) check(studio.open_body(QString::fromStdString(*o.body), o.body_options), "--body");
    for (const GarmentSpec& g : o.garments) check(studio.add_garment(g), "--garment");
    if (o.drape_seconds > 0) {
      studio.drape(o.drape_seconds);
      // A scripted run waits for it, so that what follows starts from the draped garment.
      QEventLoop wait;
      QTimer poll;
      QObject::connect(&poll, &QTimer::timeout, &wait, [&] {
        if (!studio.draping()) wait.quit();
      });
      poll.start(20);
      wait.exec();
    }
    if (o.tool) {
      if (studio.tools().has(*o.tool)) {
        window.tool_panel().choose(*o.tool);
      } else {
        std::string known;
        for (const std::string& id : studio.tools().ids()) known += " " + id;
        std::fprintf(stderr, "kiji-studio: there is no tool '%s'; the tools are:%s\n", o.tool->c_str(), known.c_str());
        ++failures;
      }
    }
    if (o.edges) window.set_edge_display(*o.edges == "all" ? EdgeDisplay::All : *o.edges == "none" ? EdgeDisplay::None : EdgeDisplay::Local);
    PhantomOptions phantom;
    phantom.library = o.hd_library;
    phantom.device_name = o.hd_device;
    // A Phantom that fails is reported and replaced by the mouse: not a failure of the run.
    studio.use_device(o.device == "phantom" ? DeviceKind::Phantom : o.device == "none" ? DeviceKind::None : DeviceKind::Mouse,
                      phantom);
    if (o.replay) check(studio.replay(QString::fromStdString(*o.replay)), "--replay");
    // After the replay: the garments as the journal left them, standing still.
    if (o.paused) studio.set_simulating(false);
  }

  void run_python() {
    for (const std::string& line : o.python) {
      QEventLoop wait;
      QObject::connect(&window.console(), &PythonConsole::finished, &wait, &QEventLoop::quit);
      window.console().submit(QString::fromStdString(line));
      if (window.console().busy()) wait.exec();
    }
  }

  void write_outputs() {
    if (o.screenshot) check(window.save_picture(QString::fromStdString(*o.screenshot)), "--screenshot");
    if (o.window_screenshot) {
      const QString path = QString::fromStdString(*o.window_screenshot);
      const bool ok = window.grab_window().save(path);
      if (!ok) std::fprintf(stderr, "kiji-studio: the window's picture was not saved to %s\n", o.window_screenshot->c_str());
      check(ok, "--window-screenshot");
    }
    if (o.save_journal) check(studio.save_journal(QString::fromStdString(*o.save_journal)), "--save-journal");
    if (o.save_session) check(studio.save_session(QString::fromStdString(*o.save_session)), "--save-session");
    if (o.export_garment) check(studio.export_garment(QString::fromStdString(*o.export_garment)), "--export");
    if (o.save_peers) check(window.save_peers(QString::fromStdString(*o.save_peers)), "--save-peers");
  }

  void share() {
    if (!o.host && !o.join) return;
    PeerSettings settings;
    settings.host = o.host;
    if (o.url) settings.url = *o.url;
    if (o.channel) settings.channel = *o.channel;
    if (o.name) settings.name = *o.name;
    if (o.key_file) settings.key_file = *o.key_file;
    settings.stop_seconds = o.seconds;
    check(studio.share_session(settings), o.host ? "--host" : "--join");
  }

  // A host's scripted run with --seconds, and a joiner's when its host set one, is over once the
  // shared clock stopped and every peer agrees there (as kiji peer's --seconds).
  bool shared_run_done() const {
    const auto view = studio.peer_view();
    return view && view->stop_step > 0 && view->step >= view->stop_step && view->converged;
  }
};

}  // namespace

int main(int argc, char** argv) {
  StudioOptions options;
  try {
    options = StudioOptions::parse(std::vector<std::string>(argv + 1, argv + argc));
  } catch (const UsageError& e) {
    std::fprintf(stderr, "kiji-studio: %s\n", e.what());
    return 2;
  }
  if (options.help) {
    std::fputs(StudioOptions::usage().c_str(), stdout);
    return 0;
  }
  if (options.version) {
    std::printf("kiji-studio %s\n", kiji::version());
    return 0;
  }

  // The viewport's format for every context, so that Qt's composition of the view shares it.
  QSurfaceFormat::setDefaultFormat(Viewport::surface_format());
  QApplication app(argc, argv);
  QApplication::setApplicationName("Kiji Studio");

  auto registry = std::make_shared<ToolRegistry>();
  for (const PluginReport& r : registry->load_plugins())
    if (!r.loaded) std::fprintf(stderr, "kiji-studio: tool plugin refused: %s: %s\n", r.path.c_str(), r.message.c_str());

  // The clock starts once the scene is set up (and a journal replayed), at zero every time: held from
  // the start, so that the simulation thread takes no step before the scene's first operation.
  Studio studio(registry, /*clock_running=*/false);
  if (!options.no_autosave)
    studio.set_autosave_folder(options.autosave_dir
                                   ? QDir(QString::fromStdString(*options.autosave_dir)).absolutePath()
                                   : QDir(QStandardPaths::writableLocation(QStandardPaths::AppDataLocation)).filePath("autosave"));
  MainWindow window(studio);
  window.resize(options.width, options.height);
  Run run{studio, window, options};
  run.set_up();
  // What the set-up posted to the simulation thread (a pause after a replay) has run before the
  // clock starts, so that a replayed design stands as the journal left it.
  studio.loop().call([](Session&) {});
  studio.set_clock_running(true);
  window.show();
  // A run for a person offers what an earlier run left unsaved; a scripted one recovers only if asked.
  if (!options.quit_after && !options.recover && !options.benchmark)
    QTimer::singleShot(0, &window, [&window] { window.offer_recovery(); });
  run.share();
  run.run_python();

  // A scripted run whose scene could not be set up stops here: what it would write would be wrong.
  if (options.quit_after && run.failures) return 1;
  if (options.benchmark) return run_benchmark(app, studio, window, options);
  // Out here, not in the block below: the timers' lambdas call it until app.exec() returns.
  bool finished = false;
  auto finish = [&] {
    if (finished) return;
    finished = true;
    run.write_outputs();
    app.exit(run.failures ? 1 : 0);
  };
  if (options.quit_after) {
    QTimer::singleShot(int(*options.quit_after * 1000), &app, [&] {
      if (options.host && options.seconds > 0 && !run.shared_run_done())
        std::fprintf(stderr, "kiji-studio: the shared clock had not stopped with every peer agreeing after --quit-after\n");
      finish();
    });
    if ((options.host && options.seconds > 0) || options.join) {
      auto* done = new QTimer(&app);
      QObject::connect(done, &QTimer::timeout, &app, [&] {
        if (run.shared_run_done()) finish();
      });
      done->start(100);
    }
  }
  return app.exec();
}
