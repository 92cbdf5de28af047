// Sewing by hand: the two borders of a seam picked one after the other, the seam shown as the pairs
// it will join, turned the other way if wanted, then sewn. Press on a border and drag along it to
// pick a stretch of it; a click picks the side of the border between its corners. The mouse's left
// button and a Phantom's first button pick (and, once both sides are picked, sew); the second
// button turns the seam. The picker holds only which vertices were picked: it reads where they are
// from each frame, and lets go of a pick that a change of the garment's topology made stale.
#pragma once

#include "frame_shapes.h"

#include <QString>

#include <cstdint>
#include <vector>

namespace kiji::studio {

class SeamPicker {
 public:
  enum class Stage { First, Second, Ready };
  Stage stage() const { return stage_; }
  int garment() const { return garment_; }
  bool picking() const { return !stretch_.empty(); }

  // The button went down on border vertex v of a garment (false, and nothing picked, for a vertex
  // not on a border, or of another garment than the first side's).
  bool press(int garment, std::uint32_t v, const GarmentShape& shape);
  // The pointer moved along the border to w, the button held.
  void drag(std::uint32_t w, const GarmentShape& shape);
  // The button came up: the stretch dragged over, or for a click the side between corners, is the
  // next side of the seam. With both sides picked, the second is turned so that the seam's ends
  // meet the nearer ends (what the hand means nearly always; flip() turns it back). A seam within
  // one piece closes one way round only (the other is a Moebius strip): it is turned that way.
  void release(const GarmentFrame& g, const GarmentShape& shape);
  // The second side runs the other way (the seam's pairs cross over); false, and nothing turned,
  // for a seam within one piece.
  bool flip();
  // Both sides are on one piece: the seam has one way round.
  bool one_piece() const { return one_piece_; }
  void clear();

  // The sides picked (the second as it will be sewn: turned when flipped), and the stretch being
  // dragged over.
  const std::vector<std::uint32_t>& first() const { return first_; }
  std::vector<std::uint32_t> second() const;
  const std::vector<std::uint32_t>& stretch() const { return stretch_; }

  // The pairs the seam will join, as stitch() matches them: by the share of each side's length.
  struct Pair {
    Vec3 a, b;
  };
  std::vector<Pair> pairs(const GarmentFrame& g, const GarmentShape& shape) const;
  // Drops the picks whose vertices are no longer in order on one border (the garment changed).
  void check(const GarmentShape* shape);
  // What to do next, for the status bar.
  QString hint() const;

 private:
  Stage stage_ = Stage::First;
  int garment_ = -1;
  std::vector<std::uint32_t> first_, second_;
  bool flipped_ = false;
  bool one_piece_ = false;
  std::vector<std::uint32_t> stretch_;
  int direction_ = 0;  // of the stretch dragged: +1 along the loop, -1 back, 0 not yet known
};

}  // namespace kiji::studio
