// A Python console dock: pybind11's embedded interpreter, in which `session` is the app's own live
// session as a `kiji.Session` (every tool a method, as in the Python package), `kiji` the package
// and `np` numpy. Statements run on the interpreter's own thread holding the session's lock, so the
// window stays responsive and the simulation waits while a statement runs.
#pragma once

#include <QPlainTextEdit>
#include <QStringList>
#include <QThread>
#include <QWidget>

#include <memory>

class QLineEdit;
class QLabel;
class QPushButton;

namespace kiji::studio {

class Studio;
class PythonWorker;

class PythonConsole : public QWidget {
  Q_OBJECT
 public:
  explicit PythonConsole(Studio& studio, QWidget* parent = nullptr);
  ~PythonConsole() override;
  // Whether this build has the console (Python and pybind11 were found when it was built).
  static bool available();
  // Runs a line as if typed (for tests and the --python option); the output arrives in output().
  void submit(const QString& line);
  QString output() const;
  bool busy() const { return busy_; }

 signals:
  void run_line(const QString& line);
  void finished();

 protected:
  bool eventFilter(QObject* watched, QEvent* event) override;

 private:
  void append(const QString& text, bool error);

  Studio& studio_;
  QPlainTextEdit* output_;
  QLineEdit* input_;
  QLabel* prompt_;
  QPushButton* stop_;
  PythonWorker* worker_ = nullptr;
  QStringList history_;
  int history_at_ = 0;
  bool busy_ = false;
};

}  // namespace kiji::studio
