// Little-endian binary writing and bounds-checked reading, for the core's binary forms (operations,
// garments, bodies, session files). The reader trusts nothing: every read and every count is
// checked against the bytes left, and a failure is an InputError naming what was being read and
// the byte where it went wrong. Internal to the core.
#pragma once

#include "kiji/error.h"
#include "kiji/types.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

namespace kiji::detail {

class ByteWriter {
 public:
  void u8(std::uint8_t v) { out_.push_back(static_cast<char>(v)); }
  void u16(std::uint16_t v) { put(v, 2); }
  void u32(std::uint32_t v) { put(v, 4); }
  void u64(std::uint64_t v) { put(v, 8); }
  void i32(std::int32_t v) { put(static_cast<std::uint32_t>(v), 4); }
  void i64(std::int64_t v) { put(static_cast<std::uint64_t>(v), 8); }
  void f64(double v) {
    std::uint64_t bits;
    std::memcpy(&bits, &v, 8);
    put(bits, 8);
  }
  void vec2(const Vec2& v) {
    f64(v.x());
    f64(v.y());
  }
  void vec3(const Vec3& v) {
    f64(v.x());
    f64(v.y());
    f64(v.z());
  }
  void str(std::string_view s) {
    u32(static_cast<std::uint32_t>(s.size()));
    out_.append(s.data(), s.size());
  }
  void bytes(std::string_view s) {
    u64(s.size());
    out_.append(s.data(), s.size());
  }
  void raw(const void* data, std::size_t n) { out_.append(static_cast<const char*>(data), n); }
  std::string take() { return std::move(out_); }
  std::size_t size() const { return out_.size(); }

 private:
  void put(std::uint64_t v, int n) {
    for (int i = 0; i < n; ++i) out_.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
  }
  std::string out_;
};

class ByteReader {
 public:
  ByteReader(std::string_view bytes, std::string what) : in_(bytes), what_(std::move(what)) {}

  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(what_ + " is malformed at byte " + std::to_string(pos_) + ": " + problem);
  }
  std::size_t left() const { return in_.size() - pos_; }
  bool at_end() const { return pos_ == in_.size(); }
  std::size_t position() const { return pos_; }

  std::uint8_t u8() { return static_cast<std::uint8_t>(get(1)); }
  std::uint16_t u16() { return static_cast<std::uint16_t>(get(2)); }
  std::uint32_t u32() { return static_cast<std::uint32_t>(get(4)); }
  std::uint64_t u64() { return get(8); }
  std::int32_t i32() { return static_cast<std::int32_t>(static_cast<std::uint32_t>(get(4))); }
  std::int64_t i64() { return static_cast<std::int64_t>(get(8)); }
  double f64() {
    const std::uint64_t bits = get(8);
    double v;
    std::memcpy(&v, &bits, 8);
    return v;
  }
  // A double that must be finite (NaN and infinity are refused, naming the field).
  double finite(const char* field) {
    const double v = f64();
    if (!std::isfinite(v)) fail(std::string(field) + " is not a finite number");
    return v;
  }
  Vec2 vec2(const char* field) {
    const double x = finite(field);
    return {x, finite(field)};
  }
  Vec3 vec3(const char* field) {
    const double x = finite(field), y = finite(field);
    return {x, y, finite(field)};
  }
  bool boolean(const char* field) {
    const std::uint8_t b = u8();
    if (b > 1) fail(std::string(field) + " is not 0 or 1");
    return b == 1;
  }
  std::string str(std::size_t max, const char* field) {
    const std::uint32_t n = u32();
    if (n > max) fail(std::string(field) + " is " + std::to_string(n) + " bytes long, over the limit of " +
                      std::to_string(max));
    return std::string(take(n));
  }
  std::string_view bytes(std::size_t max, const char* field) {
    const std::uint64_t n = u64();
    if (n > max || n > left())
      fail(std::string(field) + " says " + std::to_string(n) + " bytes, but " + std::to_string(left()) + " are left");
    return take(static_cast<std::size_t>(n));
  }
  // A count of records of at least `record_bytes` each: refused if over `max` or if the bytes left
  // cannot hold that many, so that nothing is allocated for records that are not there.
  std::size_t count(std::size_t max, std::size_t record_bytes, const char* field) {
    const std::uint32_t n = u32();
    if (n > max) fail(std::string(field) + " is " + std::to_string(n) + ", over the limit of " + std::to_string(max));
    if (record_bytes > 0 && n > left() / record_bytes)
      fail(std::string(field) + " is " + std::to_string(n) + ", more than the " + std::to_string(left()) +
           " bytes left can hold");
    return n;
  }
  std::string_view take(std::size_t n) {
    if (n > left()) fail("needs " + std::to_string(n) + " more bytes, " + std::to_string(left()) + " are left");
    std::string_view s = in_.substr(pos_, n);
    pos_ += n;
    return s;
  }

 private:
  std::uint64_t get(int n) {
    if (left() < static_cast<std::size_t>(n))
      fail("ends early (" + std::to_string(n) + " bytes wanted, " + std::to_string(left()) + " left)");
    std::uint64_t v = 0;
    for (int i = 0; i < n; ++i) v |= std::uint64_t(static_cast<unsigned char>(in_[pos_ + i])) << (8 * i);
    pos_ += n;
    return v;
  }
  std::string_view in_;
  std::size_t pos_ = 0;
  std::string what_;
};

// Reads a binary form's version and refuses 0 or one later than `newest`, naming both; returns it.
inline std::uint16_t check_format_version(ByteReader& r, std::uint16_t newest, const char* what) {
  const std::uint16_t v = r.u16();
  const std::string reads = "; this Kiji reads versions 1 to " + std::to_string(newest);
  if (v == 0)
    r.fail(std::string(what) + " format version 0" + reads + ": no Kiji writes version 0, so the bytes are damaged or not Kiji's");
  if (v > newest) r.fail(std::string(what) + " format version " + std::to_string(v) + reads + ": use a newer Kiji");
  return v;
}

}  // namespace kiji::detail
