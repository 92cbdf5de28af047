// The Peers dock of a shared session: each peer's name and colour, its role (the sequencer, which
// orders everyone's edits), the cloth it has leased, how long since it was heard from, and whether
// its state hash agrees with this app's. Refreshed from the copy Studio takes under the session's
// lock when that is free (the list never waits on a step or on the network).
#pragma once

#include <QJsonArray>
#include <QWidget>

#include <memory>

class QLabel;
class QTableWidget;

namespace kiji::studio {

class Studio;
struct PeerView;

class PeersPanel : public QWidget {
  Q_OBJECT
 public:
  explicit PeersPanel(Studio& studio, QWidget* parent = nullptr);
  // The rows as shown: {"name", "colour" (#rrggbb), "role", "leased", "heard", "state", "present"}.
  QJsonArray rows() const;
  QString summary() const;

 public slots:
  void refresh();

 private:
  Studio& studio_;
  QLabel* summary_;
  QTableWidget* table_;
  std::shared_ptr<const PeerView> shown_;
};

}  // namespace kiji::studio
