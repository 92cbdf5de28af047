// Picking: which point of which garment a pointer is on. A 3D pen picks the cloth nearest it; a
// mouse casts a ray from the eye and picks where the ray first meets the cloth.
#pragma once

#include "kiji/garment.h"
#include "kiji/tool_event.h"

#include <vector>

namespace kiji {

// The cloth surface point nearest `position` within `radius` (ray zero), or where the ray from
// `position` along `ray` first meets the cloth (ray non-zero; radius unused). hit = false if none;
// hit.garment is the index in `garments`. The first of equally near points wins, as a loop over
// the garments and their faces in order would find it.
SurfaceHit pick(const std::vector<Garment>& garments, const Vec3& position, const Vec3& ray, double radius);

}  // namespace kiji
