// Topology edits: the only ways the tools change a garment's connectivity.
//
// Each one either succeeds, leaving a valid manifold triangle mesh (no isolated or non-manifold
// vertices) and bumping the topology version, or throws TopologyError / InputError and leaves the
// garment exactly as it was. Properties travel with the elements: positions, velocities and masses
// with vertices, uv with face corners, rest length and tear threshold with edges, panel with faces.
#pragma once

#include "kiji/garment.h"

#include <optional>
#include <vector>

namespace kiji {

// Splits v in two: the faces in `moved` (each incident to v) go to a new vertex at v's position;
// the other faces keep v. Edges between a moved and a kept face are duplicated, so the cloth opens
// there (the paper's cut). Returns the new vertex.
Vertex split_vertex(Garment& g, Vertex v, const std::vector<Face>& moved);

// Splits v along the edges (v, a) and (v, b), both incident to v: the faces of v's fan met going
// counter-clockwise from edge (v, a) to edge (v, b) move to the new vertex. On a border vertex, a
// may equal b for a single cut from the border.
Vertex split_vertex_between(Garment& g, Vertex v, Vertex a, Vertex b);

// Cuts the cloth along a path of vertices joined by edges (a knife stroke): every edge of the path
// is opened, so the faces on its two sides no longer meet there. Inner path vertices are split in
// two; an end of the path is split only if it lies on the border (a cut that runs into the cloth
// ends in a slit). A path from border to border separates the cloth into pieces. No face is lost.
// Returns the vertices created.
std::vector<Vertex> cut_along(Garment& g, const std::vector<Vertex>& path);

// A line drawn on the cloth for the knife: the face it starts on and the points it passes through,
// in order, the first on that face. Each point is reached by walking over the surface from the one
// before, so the line stays on the layer it began on where the cloth lies folded over itself (a
// point on another layer is reached only as far as the surface leads there).
struct KnifeLine {
  Face start;
  std::vector<Vec3> points;
  // The line comes back to its start: what it encloses is cut out.
  bool closed = false;
  // Where the stroke was off the cloth before its first point, or after its last: the line goes on
  // over the surface towards it, to the border if the border lies on the way.
  std::optional<Vec3> from, to;
  // For a line drawn in a view: the direction of the view's ray at each point (empty: none). Between
  // two points the line follows where the surface meets the sheet those rays sweep, so that it lies
  // under the stroke as seen, over folds and slopes a walk towards the next point stops on. A
  // closed one with faces (below) cuts round the cloth it encloses as seen, through every layer
  // within its width of where it was drawn; where that, or the sheet, does not cut out one piece,
  // it is walked.
  std::vector<Vec3> sweeps;
  // For a line through points known on the cloth (a script's cut through points it chose): each
  // point's face and its corners' weights (halfedge order from halfedge(face)). Between two points
  // the line then goes straight in the flat pattern, across folds and wrinkles that a walk over the
  // surface stops at. Empty: the line is walked over the surface. With sweeps: the faces a closed
  // stroke touched, where what it encloses as seen starts.
  std::vector<Face> faces;
  std::vector<Vec3> weights;
};

struct KnifeCut {
  std::vector<Vertex> opening;  // the vertices along the cut, in order (one side's)
  std::vector<Vertex> created;  // vertices made: where the line crosses edges, and by opening it
  std::vector<Vec3> line;       // the line as followed over the surface: where it crosses each edge
  bool closed = false;          // the line was closed and its inside cut out
};

// Cuts the cloth along a drawn line: where the line crosses an edge a vertex is made (or, within
// three tenths of the edge from a vertex, that vertex is moved onto the line: no sliver triangles),
// the faces crossed are triangulated again with the line's pieces as edges, and the line is opened.
// A line that runs into the cloth ends in a slit; border to border, or closed, it makes pieces. A
// line that crosses itself inside one triangle is refused (InputError), changing nothing.
KnifeCut cut_line(Garment& g, const KnifeLine& line);

// Whether a stroke's points on the cloth make a closed line for the knife: its end came back
// within `within` metres of its start after going more than twice that away (the cut tool's rule,
// which an app's preview shares).
bool knife_line_closes(const std::vector<Vec3>& points, double within);

// The line the knife would follow, without cutting: a preview.
std::vector<Vec3> trace_line(const Garment& g, const KnifeLine& line);

// The shortest path of edges from `from` to `to` (Dijkstra on edge lengths); throws InputError if
// they are not connected.
std::vector<Vertex> edge_path(const Garment& g, Vertex from, Vertex to);

// Removes edge e with its one or two faces (the paper's tear). Vertices left with no face are
// removed; a vertex whose fan falls into separate wedges is split, one vertex a wedge.
void remove_edge(Garment& g, Edge e);

// Removes many edges and their faces at once, with the same rules.
void remove_edges(Garment& g, const std::vector<Edge>& edges);

// Merges `gone` into `keep` (the paper's sew): faces of `gone` now use `keep`, which moves to the
// midpoint; edges that then coincide become one. If the pieces had opposite orientations, the piece
// of `gone` is flipped first. Refused (TopologyError) when the result would be non-manifold, e.g.
// two interior vertices, or two separate pieces touching at a single vertex.
Vertex merge_vertices(Garment& g, Vertex keep, Vertex gone);

// Sews two border polylines into a seam: a[0] meets b[0], ..., the last meets the last. The
// polylines may have different vertex counts: the shorter sides are refined by arc length first.
// Afterwards no border is left along the seam.
void stitch(Garment& g, const std::vector<Vertex>& a, const std::vector<Vertex>& b);

// A seam sewn as it closes: the sides matched as stitch() matches them (refined by arc length), and
// each pair tacked (Garment::tacks), so that the solver draws the two borders together over the
// next steps instead of joining them where they are. A session sews the tacks as they meet
// (close_tacks). Returns the pairs tacked. Refuses what stitch() refuses, changing nothing.
std::vector<std::pair<Vertex, Vertex>> tack_seam(Garment& g, const std::vector<Vertex>& a,
                                                 const std::vector<Vertex>& b);

// Sews every run of met tacks (tack_met) that follow one another along both borders, merging the
// pairs as tacked; a run goes on to the vertex both its borders lead to (where the seam is already
// sewn, or a shared corner). A met pair alone waits for a neighbour (merged alone it would pinch the
// cloth), unless its two vertices are border neighbours; a run the mesh cannot take stays tacked.
// Returns the number of pairs sewn.
std::size_t close_tacks(Garment& g, double within);

// Whether the tacked pair (a, b) has met: its vertices within `within` of each other; or, for a
// seam's last pair (its vertices border neighbours of one vertex, the seam's sewn end or a shared
// corner, and nothing tacked beyond them), within twice that: the body or the cloth can hold that
// pair apart as far as its two edges to the end differ, and sewn it moves each vertex less than an
// edge.
bool tack_met(const Garment& g, Vertex a, Vertex b, double within);

// Adds every vertex and face of `other` to `g` as separate pieces (e.g. the panels of one garment),
// keeping their properties; returns the index that `other`'s vertex 0 now has (vertex i of other
// becomes first + i when other has no removed vertices).
Vertex append_garment(Garment& g, const Garment& other);

// The border loops of the garment, each as its vertices in order.
std::vector<std::vector<Vertex>> border_loops(const Garment& g);

// The border vertices from `from` to `to` walking along the border (forward along border
// halfedges). Throws InputError if they are not on one border loop.
std::vector<Vertex> border_path(const Garment& g, Vertex from, Vertex to);

}  // namespace kiji
