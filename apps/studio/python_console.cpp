// Python's headers name a struct member `slots`, which Qt defines as a macro: they come first.
#if KIJI_STUDIO_PYTHON
#pragma push_macro("slots")
#undef slots
#include <pybind11/embed.h>
#include <pybind11/stl.h>
#pragma pop_macro("slots")
namespace py = pybind11;
#endif

#include "python_console.h"

#include "studio.h"

#include "kiji/session.h"

#include <QHBoxLayout>
#include <QKeyEvent>
#include <QLabel>
#include <QLineEdit>
#include <QPushButton>
#include <QVBoxLayout>

#include <cstdlib>

namespace kiji::studio {

// Lives on the console's thread: the interpreter is started, used and stopped there only.
class PythonWorker : public QObject {
  Q_OBJECT
 public:
  explicit PythonWorker(Studio& studio) : studio_(studio) {}
  ~PythonWorker() override = default;

 public slots:
  void start();
  void run(const QString& line);
  void rebind();
  void stop();

 signals:
  void text(const QString& text, bool error);
  void prompt(const QString& prompt);
  void done();

 private:
  Studio& studio_;
#if KIJI_STUDIO_PYTHON
  py::object console_;
  py::object locals_;  // a dict once the interpreter runs (a py::dict would be made before it)
#endif
  bool ready_ = false;
};

#if KIJI_STUDIO_PYTHON

namespace {

// The interpreter of the virtual environment the app was built with (its site-packages has kiji
// and numpy), unless KIJI_PYTHON names another.
std::string venv_python() {
  if (const char* p = std::getenv("KIJI_PYTHON"); p && *p) return p;
  return KIJI_STUDIO_VENV_PYTHON;
}

}  // namespace

namespace {

// One interpreter for the process, on a thread of its own, started by the first console and kept
// until the process ends: numpy, like many extension modules, cannot be imported again into a
// second interpreter after the first is finalised, and a window may be opened more than once.
struct PythonHost {
  QThread thread;
  std::unique_ptr<py::scoped_interpreter> interpreter;
  std::string failure;  // why it could not start
};

PythonHost& host() {
  static PythonHost* h = [] {
    auto* p = new PythonHost;  // never deleted: the interpreter lives as long as the process
    p->thread.setObjectName("python");
    p->thread.start();
    return p;
  }();
  return *h;
}

// Starts the interpreter (on the host's thread); false, with the reason in host().failure, if it
// cannot.
bool start_interpreter(const std::function<void(const std::string&, bool)>& emit_text) {
  PythonHost& h = host();
  if (h.interpreter) return true;
  if (!h.failure.empty()) return false;
  try {
    // numpy's BLAS starts a thread a core that spins between calls, taking cycles from the
    // simulation and the drawing; a console's scripts do not need it.
    setenv("OPENBLAS_NUM_THREADS", "1", 0);
    PyConfig config;
    PyConfig_InitPythonConfig(&config);
    // Python's SIGINT handler, so that the Stop button (PyErr_SetInterrupt) raises KeyboardInterrupt,
    // which also stops Kiji's long calls (simulate, drape, replay) between steps.
    config.install_signal_handlers = 1;
    config.parse_argv = 0;
    const std::string program = venv_python();
    PyConfig_SetBytesString(&config, &config.program_name, program.c_str());
    h.interpreter = std::make_unique<py::scoped_interpreter>(&config);
    py::module_ sys = py::module_::import("sys");
    // The package built beside this app first: its module matches the app's libkiji.
    const std::string staged = KIJI_STUDIO_STAGED_PACKAGE;
    if (!staged.empty()) sys.attr("path").attr("insert")(0, staged);
    py::cpp_function write_out([emit_text](const std::string& s) { emit_text(s, false); return s.size(); });
    py::cpp_function write_err([emit_text](const std::string& s) { emit_text(s, true); return s.size(); });
    py::dict ns;
    ns["write_out"] = write_out;
    ns["write_err"] = write_err;
    py::exec(R"(
class _Stream:
    def __init__(self, write):
        self._write = write
    def write(self, s):
        return self._write(s)
    def flush(self):
        pass
    def isatty(self):
        return False
import sys
sys.stdout = _Stream(write_out)
sys.stderr = _Stream(write_err)
)",
             ns);
    py::module_::import("numpy");
    py::module_::import("kiji");
    return true;
  } catch (const std::exception& e) {
    h.failure = e.what();
    return false;
  }
}

// The console whose statement runs now: the interpreter's output goes to it.
PythonWorker* speaking = nullptr;

}  // namespace

void PythonWorker::start() {
  speaking = this;
  if (!start_interpreter([](const std::string& s, bool error) {
        if (speaking) emit speaking->text(QString::fromStdString(s), error);
      })) {
    emit text(QString("The Python console could not start: %1\nIt needs the virtual environment Kiji was built "
                      "with (scripts/setup.sh makes .venv), or KIJI_PYTHON set to a Python with kiji and numpy.\n")
                  .arg(QString::fromStdString(host().failure)),
              true);
    emit prompt(">>> ");
    return;
  }
  try {
    py::module_ sys = py::module_::import("sys");
    py::module_ kiji = py::module_::import("kiji");
    py::dict locals;
    locals["__name__"] = "__console__";
    locals["kiji"] = kiji;
    locals["np"] = py::module_::import("numpy");
    locals_ = locals;
    console_ = py::module_::import("code").attr("InteractiveConsole")(locals_);
    ready_ = true;
    rebind();
    emit text(QString("Python %1, kiji %2 from %3\n"
                      "`session` is this window's session: session.garment(0), session.cut(points), session.undo(), "
                      "help(session.pinch)\n")
                  .arg(QString::fromStdString(sys.attr("version").cast<std::string>().substr(0, 6)),
                       QString::fromStdString(kiji.attr("__version__").cast<std::string>()),
                       QString::fromStdString(py::str(kiji.attr("__file__")).cast<std::string>())),
              false);
  } catch (const std::exception& e) {
    emit text(QString("The Python console could not start: %1\n").arg(e.what()), true);
  }
  emit prompt(">>> ");
}

void PythonWorker::rebind() {
  if (!ready_) return;
  try {
    py::gil_scoped_acquire gil;
    py::object kiji = py::module_::import("kiji");
    py::object handle = py::cast(studio_.session());
    locals_["session"] = kiji.attr("Session")(py::arg("_core") = handle);
  } catch (const std::exception& e) {
    emit text(QString("`session` is not available: %1\n").arg(e.what()), true);
  }
}

void PythonWorker::run(const QString& line) {
  if (!ready_) {
    emit text("The Python console is not running.\n", true);
    emit done();
    return;
  }
  speaking = this;
  bool more = false;
  {
    // The simulation waits while the statement runs: it sees the session as the statement left it.
    auto lock = studio_.loop().hold();
    try {
      more = console_.attr("push")(line.toStdString()).cast<bool>();
    } catch (py::error_already_set& e) {
      if (e.matches(PyExc_SystemExit)) emit text("exit() does not close Kiji Studio: use File > Quit.\n", true);
      else emit text(QString::fromStdString(e.what()) + "\n", true);
      console_.attr("resetbuffer")();
    } catch (const std::exception& e) {
      emit text(QString::fromStdString(e.what()) + "\n", true);
    }
  }
  emit prompt(more ? "... " : ">>> ");
  emit done();
}

void PythonWorker::stop() {
  // The interpreter stays for the next window; this console's names go.
  if (speaking == this) speaking = nullptr;
  if (!ready_) return;
  try {
    locals_.attr("clear")();
    locals_ = py::object();
    console_ = py::object();
  } catch (...) {
  }
  ready_ = false;
}

bool PythonConsole::available() { return true; }

#else

void PythonWorker::start() {
  emit text("This build of Kiji Studio has no Python console: Python's development files or pybind11 were not "
            "found when it was built (scripts/setup.sh installs both).\n",
            true);
}
void PythonWorker::run(const QString&) { emit done(); }
void PythonWorker::rebind() {}
void PythonWorker::stop() {}
bool PythonConsole::available() { return false; }

#endif

PythonConsole::PythonConsole(Studio& studio, QWidget* parent) : QWidget(parent), studio_(studio) {
  auto* layout = new QVBoxLayout(this);
  layout->setContentsMargins(2, 2, 2, 2);
  output_ = new QPlainTextEdit(this);
  output_->setObjectName("console_output");
  output_->setReadOnly(true);
  output_->setMaximumBlockCount(5000);
  QFont mono("Monospace");
  mono.setStyleHint(QFont::TypeWriter);
  output_->setFont(mono);
  auto* row = new QHBoxLayout;
  prompt_ = new QLabel(">>> ", this);
  prompt_->setFont(mono);
  input_ = new QLineEdit(this);
  input_->setObjectName("console_input");
  input_->setFont(mono);
  input_->installEventFilter(this);
  stop_ = new QPushButton("Stop", this);
  stop_->setToolTip("Interrupts the running statement (KeyboardInterrupt)");
  stop_->setEnabled(false);
  row->addWidget(prompt_);
  row->addWidget(input_, 1);
  row->addWidget(stop_);
  layout->addWidget(output_, 1);
  layout->addLayout(row);

  worker_ = new PythonWorker(studio);
#if KIJI_STUDIO_PYTHON
  worker_->moveToThread(&host().thread);
#endif
  connect(this, &PythonConsole::run_line, worker_, &PythonWorker::run);
  connect(worker_, &PythonWorker::text, this, &PythonConsole::append);
  connect(worker_, &PythonWorker::prompt, prompt_, &QLabel::setText);
  connect(worker_, &PythonWorker::done, this, [this] {
    busy_ = false;
    stop_->setEnabled(false);
    emit finished();
  });
  connect(&studio, &Studio::session_replaced, worker_, &PythonWorker::rebind);
  connect(input_, &QLineEdit::returnPressed, this, [this] {
    const QString line = input_->text();
    input_->clear();
    submit(line);
  });
  connect(stop_, &QPushButton::clicked, this, [] {
#if KIJI_STUDIO_PYTHON
    PyErr_SetInterrupt();
#endif
  });
  QMetaObject::invokeMethod(worker_, &PythonWorker::start, Qt::QueuedConnection);
}

PythonConsole::~PythonConsole() {
#if KIJI_STUDIO_PYTHON
  if (busy_) PyErr_SetInterrupt();
#endif
#if KIJI_STUDIO_PYTHON
  QMetaObject::invokeMethod(worker_, &PythonWorker::stop, Qt::BlockingQueuedConnection);
  worker_->deleteLater();
#else
  delete worker_;
#endif
}

void PythonConsole::submit(const QString& line) {
  append(prompt_->text() + line + "\n", false);
  if (!line.trimmed().isEmpty() && (history_.isEmpty() || history_.back() != line)) history_.push_back(line);
  history_at_ = history_.size();
  busy_ = true;
  stop_->setEnabled(true);
  emit run_line(line);
}

QString PythonConsole::output() const { return output_->toPlainText(); }

void PythonConsole::append(const QString& text, bool error) {
  QTextCharFormat f;
  f.setForeground(error ? QColor(170, 20, 20) : palette().color(QPalette::Text));
  QTextCursor c = output_->textCursor();
  c.movePosition(QTextCursor::End);
  c.insertText(text, f);
  output_->setTextCursor(c);
  output_->ensureCursorVisible();
}

bool PythonConsole::eventFilter(QObject* watched, QEvent* event) {
  if (watched == input_ && event->type() == QEvent::KeyPress) {
    auto* k = static_cast<QKeyEvent*>(event);
    if (k->key() == Qt::Key_Up && !history_.isEmpty()) {
      history_at_ = std::max(0, history_at_ - 1);
      input_->setText(history_[history_at_]);
      return true;
    }
    if (k->key() == Qt::Key_Down && !history_.isEmpty()) {
      history_at_ = std::min<int>(history_.size(), history_at_ + 1);
      input_->setText(history_at_ < history_.size() ? history_[history_at_] : QString());
      return true;
    }
  }
  return QWidget::eventFilter(watched, event);
}

}  // namespace kiji::studio

#include "python_console.moc"
