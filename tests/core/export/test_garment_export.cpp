// Garment files: .glb and .obj round trips (positions, uv seams, colour, texture) and errors.
#include "kiji/body.h"
#include "kiji/error.h"
#include "support/test_errors.h"
#include "support/test_png.h"
#include "kiji/io.h"
#include "kiji/pattern.h"
#include "kiji/render.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <tuple>

using namespace kiji;
using kiji::test::input_error;

namespace {

std::string tmp_path(const std::string& name) {
  std::filesystem::create_directories(KIJI_TEST_TMP);
  return std::string(KIJI_TEST_TMP) + "/" + name;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// A 1 x 0.5 m rectangle, 5 x 3 vertices, draped a little out of plane, with a uv seam down the
// middle column: the left half's uvs are shifted, so each vertex of x = 0.5 has two uvs.
Garment seamed_garment() {
  Garment g = make_rectangle(1.0, 0.5, 5, 3);
  g.name = "skirt";
  g.color = Vec3(0.1, 0.6, 0.3);
  const Mesh& m = g.mesh();
  for (Vertex v : m.vertices()) {
    Vec3 p = g.position(v);
    p.z() = 0.1 * std::sin(3 * p.x()) + 0.05 * p.y();
    g.set_position(v, p);
  }
  for (Face f : m.faces()) {
    double cx = 0;
    for (Vertex v : CGAL::vertices_around_face(m.halfedge(f), m)) cx += g.position(v).x() / 3;
    if (cx < 0.5)
      for (Halfedge h : CGAL::halfedges_around_face(m.halfedge(f), m)) g.set_uv(h, g.uv(h) + Vec2(0.25, 0.125));
  }
  return g;
}

// 7 x 5 texels, every one different, so a flipped or transposed image cannot pass.
Texture test_texture() {
  Texture t = Texture::filled(7, 5, 0, 0, 0);
  for (int y = 0; y < t.height; ++y)
    for (int x = 0; x < t.width; ++x) {
      std::uint8_t* p = t.texel(x, y);
      p[0] = static_cast<std::uint8_t>(30 * x + 1);
      p[1] = static_cast<std::uint8_t>(50 * y + 2);
      p[2] = static_cast<std::uint8_t>(7 * x * y + 3);
      p[3] = static_cast<std::uint8_t>(255 - 10 * x - y);
    }
  return t;
}

std::size_t count_uv_corners(const Garment& g) {
  std::set<std::tuple<std::size_t, double, double>> s;
  for (Face f : g.mesh().faces())
    for (Halfedge h : CGAL::halfedges_around_face(g.mesh().halfedge(f), g.mesh()))
      s.emplace(g.mesh().target(h).idx(), g.uv(h).x(), g.uv(h).y());
  return s.size();
}

// Every face of `b` matches a face of `a` with the same corner positions and uvs (float precision).
void expect_same_surface(const Garment& a, const Garment& b) {
  ASSERT_EQ(a.mesh().number_of_vertices(), b.mesh().number_of_vertices());
  ASSERT_EQ(a.mesh().number_of_faces(), b.mesh().number_of_faces());
  ASSERT_EQ(a.mesh().number_of_edges(), b.mesh().number_of_edges());
  // Match vertices by position.
  auto key = [](const Vec3& p) {
    return std::make_tuple(std::llround(p.x() * 1e5), std::llround(p.y() * 1e5), std::llround(p.z() * 1e5));
  };
  std::map<std::tuple<long long, long long, long long>, Vertex> by_pos;
  for (Vertex v : a.mesh().vertices()) by_pos[key(a.position(v))] = v;
  ASSERT_EQ(by_pos.size(), a.mesh().number_of_vertices());
  std::map<Vertex, Vertex> b_to_a;
  for (Vertex v : b.mesh().vertices()) {
    auto it = by_pos.find(key(b.position(v)));
    ASSERT_NE(it, by_pos.end()) << "vertex at " << b.position(v).transpose() << " is not in the original";
    EXPECT_TRUE(b.position(v).isApprox(a.position(it->second), 1e-6));
    b_to_a[v] = it->second;
  }
  // Faces by their vertex set; corner uv by vertex.
  std::map<std::set<Vertex>, std::map<Vertex, Vec2>> faces_a;
  for (Face f : a.mesh().faces()) {
    std::map<Vertex, Vec2> corners;
    for (Halfedge h : CGAL::halfedges_around_face(a.mesh().halfedge(f), a.mesh())) corners[a.mesh().target(h)] = a.uv(h);
    std::set<Vertex> vs;
    for (auto& c : corners) vs.insert(c.first);
    faces_a[vs] = corners;
  }
  for (Face f : b.mesh().faces()) {
    std::set<Vertex> vs;
    for (Vertex v : CGAL::vertices_around_face(b.mesh().halfedge(f), b.mesh())) vs.insert(b_to_a[v]);
    auto it = faces_a.find(vs);
    ASSERT_NE(it, faces_a.end()) << "a face of the file is not in the original";
    for (Halfedge h : CGAL::halfedges_around_face(b.mesh().halfedge(f), b.mesh())) {
      const Vec2 uv_a = it->second.at(b_to_a[b.mesh().target(h)]);
      EXPECT_NEAR(b.uv(h).x(), uv_a.x(), 1e-6);
      EXPECT_NEAR(b.uv(h).y(), uv_a.y(), 1e-6);
    }
  }
  // Rest lengths are the lengths in the file.
  for (Edge e : b.mesh().edges()) EXPECT_NEAR(b.rest_length(e), b.length(e), 1e-12);
}

void expect_same_texture(const Texture& a, const Texture& b) {
  ASSERT_EQ(a.width, b.width);
  ASSERT_EQ(a.height, b.height);
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x)
      for (int c = 0; c < 4; ++c) ASSERT_EQ(a.texel(x, y)[c], b.texel(x, y)[c]) << "texel " << x << "," << y;
}

}  // namespace

TEST(GarmentFiles, SeamedGarmentHasTwoUvsOnTheSeam) {
  Garment g = seamed_garment();
  EXPECT_EQ(count_uv_corners(g), g.mesh().number_of_vertices() + 3) << "the 3 seam vertices carry two uvs";
}

TEST(GarmentFiles, GlbRoundTripKeepsPositionsUvSeamsAndColour) {
  const Garment g = seamed_garment();
  const std::string path = tmp_path("skirt.glb");
  export_garment(g, path);
  Garment back = import_garment(path);
  expect_same_surface(g, back);
  EXPECT_EQ(count_uv_corners(back), count_uv_corners(g)) << "the seam stays one vertex with two uvs";
  EXPECT_TRUE(back.color.isApprox(g.color, 1e-6)) << back.color.transpose();
  EXPECT_TRUE(back.texture().empty());
  EXPECT_EQ(back.name, "skirt");
  EXPECT_TRUE(back.is_valid());
  EXPECT_EQ(back.count_pieces(), 1u);
}

TEST(GarmentFiles, ObjRoundTripKeepsPositionsUvSeamsAndColour) {
  const Garment g = seamed_garment();
  const std::string path = tmp_path("skirt.obj");
  export_garment(g, path);
  Garment back = import_garment(path);
  expect_same_surface(g, back);
  EXPECT_EQ(count_uv_corners(back), count_uv_corners(g));
  EXPECT_TRUE(back.color.isApprox(g.color, 1e-6)) << back.color.transpose();
  const std::string mtl = slurp(tmp_path("skirt.mtl"));
  const auto kd = mtl.find("Kd ");
  ASSERT_NE(kd, std::string::npos) << mtl;
  std::istringstream in(mtl.substr(kd + 3));
  Vec3 c;
  in >> c.x() >> c.y() >> c.z();
  EXPECT_TRUE(c.isApprox(g.color, 1e-6)) << mtl;
  EXPECT_EQ(mtl.find("map_Kd"), std::string::npos) << "no texture, no map";
}

TEST(GarmentFiles, GlbEmbedsTheTextureAsPng) {
  Garment g = seamed_garment();
  g.texture() = test_texture();
  const std::string path = tmp_path("painted.glb");
  export_garment(g, path);
  const std::string bytes = slurp(path);
  ASSERT_GT(bytes.size(), 20u);
  EXPECT_EQ(bytes.substr(0, 4), "glTF");
  EXPECT_EQ(static_cast<int>(bytes[4]), 2) << "glTF version 2";
  EXPECT_NE(bytes.find("image/png"), std::string::npos);
  EXPECT_NE(bytes.find("\x89PNG"), std::string::npos) << "the PNG is inside the .glb";
  EXPECT_FALSE(std::filesystem::exists(tmp_path("painted.png"))) << "nothing written beside a .glb";

  Garment back = import_garment(path);
  expect_same_surface(g, back);
  expect_same_texture(g.texture(), back.texture());
}

TEST(GarmentFiles, ObjWritesThePngBesideAndReadsItBack) {
  Garment g = seamed_garment();
  g.texture() = test_texture();
  const std::string path = tmp_path("painted_obj.obj");
  std::filesystem::remove(tmp_path("painted_obj.png"));
  export_garment(g, path);
  ASSERT_TRUE(std::filesystem::exists(tmp_path("painted_obj.png")));
  const std::string mtl = slurp(tmp_path("painted_obj.mtl"));
  EXPECT_NE(mtl.find("map_Kd painted_obj.png"), std::string::npos) << mtl;

  Garment back = import_garment(path);
  expect_same_surface(g, back);
  expect_same_texture(g.texture(), back.texture());
}

TEST(GarmentFiles, TextureRowsFollowUv) {
  // Texture row 0 is v = 0, and viewers put v = 0 at the bottom of the image: the PNG beside the
  // OBJ, read as a plain image (row 0 at the top), must hold texture row 0 as its last row.
  Garment g = seamed_garment();
  g.texture() = test_texture();
  export_garment(g, tmp_path("rows.obj"));
  const Image png = read_png(tmp_path("rows.png"));
  ASSERT_EQ(png.width, g.texture().width);
  ASSERT_EQ(png.height, g.texture().height);
  for (int y = 0; y < png.height; ++y)
    for (int x = 0; x < png.width; ++x)
      for (int c = 0; c < 4; ++c)
        ASSERT_EQ(png.rgba[4 * ((png.height - 1 - y) * png.width + x) + c], g.texture().texel(x, y)[c]);
}

TEST(GarmentFiles, ExportedFilesAreReadableByAssimp) {
  // Body::load goes through assimp with no Kiji-specific reading: the files must be plain glTF/OBJ.
  const Garment g = seamed_garment();
  for (const char* name : {"plain.glb", "plain.obj"}) {
    export_garment(g, tmp_path(name));
    BodyImportOptions o;
    o.recenter = false;
    Body b = Body::load(tmp_path(name), o);
    EXPECT_EQ(b.triangles().size(), g.mesh().number_of_faces()) << name;
    EXPECT_EQ(b.vertices().size(), g.mesh().number_of_vertices()) << name;
    EXPECT_TRUE(b.bounds().min().isApprox(g.bounds().min(), 1e-6)) << name;
    EXPECT_TRUE(b.bounds().max().isApprox(g.bounds().max(), 1e-6)) << name;
  }
}

TEST(GarmentFiles, ReadsAThirdPartyGlbWithEmbeddedTexture) {
  // Khronos' textured box: 24 corners over 8 positions, so every vertex carries several uvs.
  Garment g = import_garment(std::string(KIJI_TEST_MODELS) + "/glTF2/BoxTextured-glTF-Binary/BoxTextured.glb");
  EXPECT_EQ(g.mesh().number_of_vertices(), 8u);
  EXPECT_EQ(g.mesh().number_of_faces(), 12u);
  EXPECT_TRUE(g.is_valid());
  EXPECT_FALSE(g.texture().empty()) << "its embedded PNG is read";
  for (Edge e : g.mesh().edges()) EXPECT_NEAR(g.rest_length(e), g.length(e), 1e-12);
}

TEST(GarmentFileErrors, UnknownExtension) {
  const Garment g = seamed_garment();
  const std::string msg = input_error([&] { export_garment(g, tmp_path("skirt.stl")); });
  EXPECT_NE(msg.find("unknown extension '.stl'"), std::string::npos) << msg;
  EXPECT_NE(msg.find(".glb"), std::string::npos) << msg;
  const std::string msg2 = input_error([&] { import_garment(tmp_path("skirt.fbx")); });
  EXPECT_NE(msg2.find("unknown extension"), std::string::npos) << msg2;
}

TEST(GarmentFileErrors, UnwritablePath) {
  const Garment g = seamed_garment();
  for (const char* p : {"/nonexistent-folder/skirt.glb", "/nonexistent-folder/skirt.obj"}) {
    const std::string msg = input_error([&] { export_garment(g, p); });
    EXPECT_NE(msg.find(p), std::string::npos) << msg;
    EXPECT_NE(msg.find("cannot be written"), std::string::npos) << msg;
  }
  const std::string dir = tmp_path("a_folder.glb");
  std::filesystem::create_directories(dir);
  EXPECT_NE(input_error([&] { export_garment(g, dir); }).find("directory"), std::string::npos);
}

TEST(GarmentFileErrors, MissingEmptyAndBrokenFiles) {
  EXPECT_NE(input_error([] { import_garment("/nonexistent/skirt.glb"); }).find("does not exist"), std::string::npos);
  const std::string empty = tmp_path("empty.glb");
  std::ofstream(empty).close();
  EXPECT_NE(input_error([&] { import_garment(empty); }).find("empty"), std::string::npos);
  const std::string broken = tmp_path("broken.glb");
  std::ofstream(broken, std::ios::binary) << "glTF this is not a real file";
  EXPECT_NE(input_error([&] { import_garment(broken); }).find("assimp cannot read it"), std::string::npos);
  const std::string lines = std::string(KIJI_TEST_MODELS) + "/OBJ/testline.obj";
  EXPECT_NE(input_error([&] { import_garment(lines); }).find("no triangles"), std::string::npos);
}

TEST(GarmentFileErrors, EmptyGarmentIsNotExported) {
  Garment g;
  EXPECT_NE(input_error([&] { export_garment(g, tmp_path("nothing.glb")); }).find("no faces"), std::string::npos);
}

TEST(GarmentFileErrors, TrianglesThatDoNotMakeAValidSurfaceAreRefused) {
  // A polygon that visits its corners twice, triangulated by assimp and welded by position: each
  // triangle is accepted as it is added, yet the surface is not valid (found by fuzz_garment_obj,
  // whose garment then failed Garment::is_valid).
  const std::string path = tmp_path("revisiting.obj");
  std::ofstream(path) << "v 0 0 0\nv 82 1 0\nv 0 1 0\nv 0 0 0\nv 1 1 01\nv  01 0 0\nv 1 1//1 2//1\nf -1 -2 -3\n"
                         "vn 0 0 1\nf 1//1 -2//1 4//1 3// 3//1 4//1 2//1\nv 1 7%4 3\ng 5 4v 0 0 0\nv 1 0 0\n"
                         "v 1 1 0.5\nf -1 -2 -3\n";
  const std::string msg = input_error([&] { import_garment(path); });
  EXPECT_NE(msg.find(path), std::string::npos) << msg;
  EXPECT_NE(msg.find("its triangles do not make a valid surface"), std::string::npos) << msg;
}

TEST(GarmentFileErrors, AFaceThatNamesAVertexTheFileDoesNotHaveIsRefused) {
  // Three vertices, and a face that names a fourth (or, counted from the end, one before the first,
  // or a texture coordinate the file lacks): refused by Kiji itself, naming the line and the count,
  // before assimp builds (and, refusing it, leaks) the meshes.
  const std::pair<const char*, const char*> cases[] = {
      {"f 1 2 4", "vertex 4, but the file has 3"},
      {"f 1 2 99999999999999999999", "the file has 3"},
      {"f -1 -2 -4", "vertex -4 (counted back), but only 3 come before it"},
      {"f 1/5 2/5 3/5", "texture coordinate 5, but the file has 0"},
      {"f 0 1 2", "vertex 0 (OBJ counts from 1)"},
      // Out of range counted back: strtoll's LLONG_MIN, which was negated (found by fuzz_garment_obj).
      {"f 1 2 -99999999999999999999", "(counted back), but only 3 come before it"},
      // A corner of another shape, which assimp read past its line (found by fuzz_body).
      {"f ////////4444444444444 1 2", "has the corner '////////4444444444444', which is not v, v/vt, v//vn or v/vt/vn"},
      // assimp takes any line starting with 'f' for a face (found by CI's fuzz phase: "f/ ...").
      {"f/ ////////4444444444444 1 2", "has the corner '////////4444444444444'"},
  };
  for (const auto& [face, says] : cases) {
    SCOPED_TRACE(face);
    const std::string path = tmp_path("bad_index.obj");
    std::ofstream(path) << "v 0 0 0\nv 1 0 0\nv 0 1 0\n" << face << "\n";
    const std::string msg = input_error([&] { import_garment(path); });
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    EXPECT_NE(msg.find("line 4"), std::string::npos) << msg;
    EXPECT_NE(msg.find(says), std::string::npos) << msg;
  }
  // Counting back from the face is the file's to do.
  const std::string path = tmp_path("good_index.obj");
  std::ofstream(path) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf -3/-1 -2/-1 -1/-1\n";
  EXPECT_EQ(import_garment(path).mesh().number_of_faces(), 1u);
  // Every shape of corner OBJ has, and a slash ending one, is read.
  for (const char* face : {"f 1 2 3", "f 1/1 2/1 3/1", "f 1//1 2//1 3//1", "f 1/1/1 2/1/1 3/1/1", "f 1/ 2/ 3/"}) {
    SCOPED_TRACE(face);
    const std::string shapes = tmp_path("corner_shapes.obj");
    std::ofstream(shapes) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n" << face << "\n";
    EXPECT_EQ(import_garment(shapes).mesh().number_of_faces(), 1u);
  }
}

TEST(GarmentFileErrors, AnEmbeddedTextureDeclaringAHugeImageIsRefused) {
  // An exported .glb whose embedded PNG is rewritten to declare another size: the import refuses
  // it before allocating its pixels, and says what the limit is.
  Garment g = seamed_garment();
  g.texture() = test_texture();
  const std::string path = tmp_path("huge_texture.glb");
  export_garment(g, path);
  const std::string original = slurp(path);
  const std::size_t png = original.find("\x89PNG");
  ASSERT_NE(png, std::string::npos);
  for (std::uint32_t side : {30000u, 8192u}) {
    std::string bytes = original;
    ASSERT_TRUE(test::declare_png_size(bytes, png, side, side));
    std::ofstream(path, std::ios::binary) << bytes;
    const std::string msg = input_error([&] { import_garment(path); });
    EXPECT_NE(msg.find("its texture '*0' is a broken PNG"), std::string::npos) << msg;
    EXPECT_NE(msg.find(side > 16384 ? "is larger than Kiji reads (at most 16384 pixels a side"
                                    : "more than a PNG file of its size can hold"),
              std::string::npos)
        << msg;
  }
}

TEST(GarmentFileErrors, AGlbImageOfAMimeTypeGltfDoesNotAllowIsRefused) {
  // assimp 5.2 reads freed memory on an image whose MIME type is neither of glTF's two; found by
  // fuzz_garment_glb. The same bytes are refused as a body too.
  Garment g = seamed_garment();
  g.texture() = test_texture();
  const std::string path = tmp_path("odd_mime.glb");
  export_garment(g, path);
  std::string bytes = slurp(path);
  const std::size_t at = bytes.find("\"image/png\"");
  ASSERT_NE(at, std::string::npos);
  bytes.replace(at, 11, "\"imageglbg\"");  // the length of the JSON chunk stays the same
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
  for (bool body : {false, true}) {
    const std::string msg = input_error([&] { body ? (void)Body::load(path) : (void)import_garment(path); });
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    EXPECT_NE(msg.find("image 0 has the MIME type \"imageglbg\", and glTF allows only"), std::string::npos) << msg;
  }
}

TEST(GarmentFileErrors, AGlbChunkLongerThanTheFileIsRefusedBeforeAssimpAllocatesIt) {
  // assimp 5.2 allocates and fills what a glb chunk declares before reading it: a JSON length of
  // 800 MB in a 2 KB file took it past 10 s and 1.3 GiB (found by fuzz_garment_glb).
  const std::string path = tmp_path("long_chunk.glb");
  export_garment(seamed_garment(), path);
  const std::string exported = slurp(path);
  auto set32 = [](std::string& b, std::size_t at, std::uint32_t v) {
    for (int k = 0; k < 4; ++k) b[at + k] = static_cast<char>((v >> (8 * k)) & 0xff);
  };
  auto get32 = [](const std::string& b, std::size_t at) {
    std::uint32_t v = 0;
    for (int k = 3; k >= 0; --k) v = (v << 8) | static_cast<unsigned char>(b[at + k]);
    return v;
  };
  std::string json = exported;
  set32(json, 12, 827131180u);
  std::string bin = exported;
  const std::size_t bin_at = (20 + get32(exported, 12) + 3) & ~std::size_t(3);
  ASSERT_EQ(exported.compare(bin_at + 4, 3, "BIN"), 0);
  set32(bin, bin_at, 0x7fffffffu);
  for (const auto& [bytes, expected] : {std::pair{json, "its glb JSON chunk declares 827131180 bytes, but the file has "},
                                        std::pair{bin, "its glb BIN chunk declares 2147483647 bytes, but the file has "}}) {
    std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
    for (bool body : {false, true}) {
      const std::string msg = input_error([&] { body ? (void)Body::load(path) : (void)import_garment(path); });
      EXPECT_NE(msg.find(path), std::string::npos) << msg;
      EXPECT_NE(msg.find(expected), std::string::npos) << msg;
    }
  }
  // The file as exported still reads.
  std::ofstream(path, std::ios::binary | std::ios::trunc) << exported;
  EXPECT_GT(import_garment(path).mesh().number_of_faces(), 0u);
}

TEST(GarmentFileErrors, AGlbNeitherGltfImporterRecognisesIsNotTriedAsEveryOtherFormat) {
  // Neither glTF importer takes these bytes; assimp then tried every format on them, and its
  // OpenGEX reader, taken by the word IndexArray, read past its buffer (found by fuzz_garment_glb).
  const std::string bytes("glTF\x02glTindexarray<\0\0\0xet\":&t\"versio+n\":\"l{\"vegene", 50);
  const std::string path = tmp_path("not_gltf.glb");
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
  for (bool body : {false, true}) {
    const std::string msg = input_error([&] { body ? (void)Body::load(path) : (void)import_garment(path); });
    EXPECT_NE(msg.find(path + "': assimp cannot read it as a .glb file (its content is not laid out as one)"), std::string::npos) << msg;
  }
  // Nor is any other name tried as OpenGEX: a name no importer claims is refused.
  const std::string other = tmp_path("not_gltf.dat");
  std::ofstream(other, std::ios::binary | std::ios::trunc) << bytes;
  EXPECT_NE(input_error([&] { Body::load(other); }).find("its extension '.dat' is not one assimp reads"), std::string::npos);
}

TEST(GarmentFileErrors, AGlbPrimitiveWithoutPositionsIsRefused) {
  // A line-loop primitive with indices and no POSITION made assimp 5.2 dereference a null array
  // (found by fuzz_garment_glb). The attribute's name is cut to keep the JSON chunk's length.
  const std::string path = tmp_path("no_positions.glb");
  export_garment(seamed_garment(), path);
  std::string bytes = slurp(path);
  const std::size_t at = bytes.find("\"attributes\"");
  ASSERT_NE(at, std::string::npos);
  bytes.replace(at, 12, "\"attrib_tes\"");
  const std::size_t mode = bytes.find("\"mode\":4");
  if (mode != std::string::npos) bytes[mode + 7] = '2';
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
  for (bool body : {false, true}) {
    const std::string msg = input_error([&] { body ? (void)Body::load(path) : (void)import_garment(path); });
    EXPECT_NE(msg.find("its mesh 0's primitive 0 has no POSITION attribute"), std::string::npos) << msg;
  }
}

TEST(GarmentFileErrors, AGlbPrimitiveWhoseAccessorHasAnUndefinedTypeIsRefused) {
  // A line-loop primitive whose index accessor's type glTF does not define made assimp 5.2
  // dereference a null array (found by fuzz_garment_glb). Each edit keeps the JSON chunk's length.
  const std::string path = tmp_path("undefined_accessor.glb");
  export_garment(seamed_garment(), path);
  const std::string exported = slurp(path);
  const std::size_t mode = exported.find("\"mode\":4");
  const std::size_t scalar = exported.find("\"SCALAR\"");
  const std::size_t component = exported.find("\"componentType\":5125");
  ASSERT_NE(scalar, std::string::npos);
  ASSERT_NE(component, std::string::npos);
  for (const auto& [at, edit, expected] :
       {std::tuple<std::size_t, std::string, std::string>{scalar, "\"SKALAR\"", "'s type \"SKALAR\" is not one of glTF's"},
        {component + 16, "5124", "'s componentType 5124 is not one of glTF's"}}) {
    std::string bytes = exported;
    bytes.replace(at, edit.size(), edit);
    if (mode != std::string::npos) bytes[mode + 7] = '2';
    std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
    for (bool body : {false, true}) {
      const std::string msg = input_error([&] { body ? (void)Body::load(path) : (void)import_garment(path); });
      EXPECT_NE(msg.find("its accessor "), std::string::npos) << msg;
      EXPECT_NE(msg.find(expected), std::string::npos) << msg;
    }
  }
}

TEST(GarmentFileErrors, ATextureBesideAnObjThatIsNotARegularFileIsRefusedWithoutBlocking) {
  Garment g = seamed_garment();
  g.texture() = test_texture();
  const std::string path = tmp_path("fifo_texture.obj"), png = tmp_path("fifo_texture.png");
  std::filesystem::remove(png);
  export_garment(g, path);
  std::filesystem::remove(png);
  ASSERT_EQ(mkfifo(png.c_str(), 0600), 0);  // opening it for reading would wait for a writer
  const std::string msg = input_error([&] { import_garment(path); });
  EXPECT_NE(msg.find("cannot be read from '" + png + "' (it is not a regular file)"), std::string::npos) << msg;
  // And writing into it would wait for a reader: the export refuses it too, as it does a FIFO in
  // the garment file's own place.
  const std::string again = input_error([&] { export_garment(g, path); });
  EXPECT_NE(again.find("its texture '" + png + "' cannot be written: it exists and is not a regular file"),
            std::string::npos)
      << again;
  const std::string fifo_glb = tmp_path("fifo_garment.glb");
  std::filesystem::remove(fifo_glb);
  ASSERT_EQ(mkfifo(fifo_glb.c_str(), 0600), 0);
  EXPECT_NE(input_error([&] { export_garment(g, fifo_glb); }).find("it exists and is not a regular file"),
            std::string::npos);
  std::filesystem::remove(png);
  std::filesystem::remove(fifo_glb);
}
