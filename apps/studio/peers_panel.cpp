#include "peers_panel.h"

#include "studio.h"

#include <QHeaderView>
#include <QIcon>
#include <QJsonObject>
#include <QLabel>
#include <QPixmap>
#include <QTableWidget>
#include <QVBoxLayout>

namespace kiji::studio {

namespace {

QColor to_qcolor(const Vec3& c) { return QColor::fromRgbF(float(c.x()), float(c.y()), float(c.z())); }

enum Column { kName, kRole, kLeased, kHeard, kState, kColumns };

}  // namespace

PeersPanel::PeersPanel(Studio& studio, QWidget* parent) : QWidget(parent), studio_(studio) {
  auto* layout = new QVBoxLayout(this);
  layout->setContentsMargins(4, 4, 4, 4);
  summary_ = new QLabel(this);
  summary_->setWordWrap(true);
  summary_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  table_ = new QTableWidget(0, kColumns, this);
  table_->setHorizontalHeaderLabels({"Peer", "Role", "Leased", "Heard", "State"});
  table_->verticalHeader()->hide();
  table_->setEditTriggers(QAbstractItemView::NoEditTriggers);
  table_->setSelectionMode(QAbstractItemView::NoSelection);
  table_->horizontalHeader()->setSectionResizeMode(QHeaderView::ResizeToContents);
  table_->horizontalHeader()->setStretchLastSection(true);
  layout->addWidget(summary_);
  layout->addWidget(table_);
  connect(&studio_, &Studio::peers_changed, this, &PeersPanel::refresh);
  connect(&studio_, &Studio::sharing_changed, this, &PeersPanel::refresh);
  refresh();
}

QString PeersPanel::summary() const { return summary_->text(); }

void PeersPanel::refresh() {
  const auto view = studio_.peer_view();
  if (view == shown_ && view) return;
  shown_ = view;
  if (!view) {
    summary_->setText(studio_.shared() ? "Connecting..." : "Not shared. File > Host session or Join session to design with others.");
    table_->setRowCount(0);
    return;
  }
  QString state;
  if (!view->joined) state = "waiting for the host's session (is a host running with this key, URL and channel?)";
  else if (view->converged) state = "every peer agrees";
  else state = "agreement not yet confirmed";
  summary_->setText(QString("%1 on %2, channel %3\nkey %4\nstep %5%6, state %7: %8")
                        .arg(view->host ? "Hosting" : "Joined", QString::fromStdString(view->url),
                             QString::fromStdString(view->channel), QString::fromStdString(view->key_file))
                        .arg(view->step)
                        .arg(view->stop_step ? QString(" (the clock stops at %1)").arg(view->stop_step) : QString())
                        .arg(view->state_hash, 16, 16, QChar('0'))
                        .arg(state));
  table_->setRowCount(int(view->peers.size()));
  for (int i = 0; i < int(view->peers.size()); ++i) {
    const PeerRow& p = view->peers[std::size_t(i)];
    QPixmap swatch(12, 12);
    swatch.fill(to_qcolor(p.colour));
    auto* name = new QTableWidgetItem(QIcon(swatch), QString::fromStdString(p.name) + (p.self ? " (you)" : ""));
    name->setData(Qt::UserRole, to_qcolor(p.colour).name());
    name->setData(Qt::UserRole + 1, p.present);
    name->setToolTip(QString("peer %1, at step %2").arg(p.id).arg(p.step));
    table_->setItem(i, kName, name);
    table_->setItem(i, kRole, new QTableWidgetItem(!p.present ? "gone" : p.sequencer ? "sequencer" : p.joined ? "peer" : "joining"));
    table_->setItem(i, kLeased, new QTableWidgetItem(p.leased_vertices ? QString("%1 vertices").arg(p.leased_vertices) : "-"));
    table_->setItem(i, kHeard, new QTableWidgetItem(p.self ? "-" : QString("%1 s ago").arg(p.heard_seconds_ago, 0, 'f', 1)));
    QString agrees = "-";
    if (!p.self) agrees = !p.hash_agrees ? "not compared yet" : *p.hash_agrees ? "agrees" : "DIFFERS (healing)";
    auto* state_item = new QTableWidgetItem(agrees);
    if (p.hash_agrees && !*p.hash_agrees) state_item->setForeground(Qt::red);
    table_->setItem(i, kState, state_item);
  }
}

QJsonArray PeersPanel::rows() const {
  QJsonArray out;
  for (int i = 0; i < table_->rowCount(); ++i) {
    const QTableWidgetItem* name = table_->item(i, kName);
    out.append(QJsonObject{{"name", name->text()},
                           {"colour", name->data(Qt::UserRole).toString()},
                           {"present", name->data(Qt::UserRole + 1).toBool()},
                           {"role", table_->item(i, kRole)->text()},
                           {"leased", table_->item(i, kLeased)->text()},
                           {"heard", table_->item(i, kHeard)->text()},
                           {"state", table_->item(i, kState)->text()}});
  }
  return out;
}

}  // namespace kiji::studio
