// Binary forms described once. A type's `fields(archive, value)` names its fields in order, and the
// same function writes them (WriteArchive) and reads them back (ReadArchive), so that a writer and
// its reader cannot drift apart. Reading checks what ByteReader checks: every length against a
// limit and the bytes left, doubles finite where a field is named, enums in range; a failure is an
// InputError naming the form, the byte and the field. Checks only a reader makes (`require`,
// `validate`, `end`) cost the writer nothing. Internal to the core.
#pragma once

#include "base/byte_io.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

namespace kiji::detail {

// The value a fields() function is given: const when it is written, to be filled in when read.
template <class Archive, class T>
using Field = std::conditional_t<Archive::reading, T, const T>;

// A length bounded only by the bytes that are there (a payload that ends its form).
constexpr std::size_t kToTheEnd = std::numeric_limits<std::size_t>::max();

class WriteArchive {
 public:
  static constexpr bool reading = false;

  void u8(std::uint8_t v) { w_.u8(v); }
  void u16(std::uint16_t v) { w_.u16(v); }
  void u32(std::uint32_t v) { w_.u32(v); }
  void u64(std::uint64_t v) { w_.u64(v); }
  void i32(std::int32_t v) { w_.i32(v); }
  void i64(std::int64_t v) { w_.i64(v); }
  void f64(double v) { w_.f64(v); }
  void finite(double v, const char*) { w_.f64(v); }
  void vec2(const Vec2& v, const char*) { w_.vec2(v); }
  void vec3(const Vec3& v, const char*) { w_.vec3(v); }
  void quaternion(const Eigen::Quaterniond& q, const char*) {
    for (double c : {q.w(), q.x(), q.y(), q.z()}) w_.f64(c);
  }
  void boolean(bool b, const char*) { w_.u8(b); }
  // An index into a list of `n` (a u32), refused with `problem` when a reader finds it past the end.
  template <class I>
  void index(I v, std::size_t, const char*) {
    w_.u32(static_cast<std::uint32_t>(v));
  }
  template <class E>
  void enumeration(E e, E, const char*) {
    w_.u8(static_cast<std::uint8_t>(e));
  }
  // Booleans packed in one byte, the first in the lowest bit.
  template <class... B>
  void flags(const char*, const B&... bits) {
    std::uint8_t packed = 0;
    int bit = 0;
    ((packed = static_cast<std::uint8_t>(packed | (bits ? 1 << bit : 0)), ++bit), ...);
    w_.u8(packed);
  }
  // Text and bytes, after their length (a u32 and a u64).
  void str(std::string_view s, std::size_t, const char*) { w_.str(s); }
  void bytes(std::string_view s, std::size_t, const char*) { w_.bytes(s); }
  // Bytes of a length the fields before them give (`n`), with no length of their own.
  template <class Bytes>
  void raw(const Bytes& b, std::size_t) {
    w_.raw(b.data(), b.size());
  }
  void shared_bytes(const std::shared_ptr<const std::string>& b, const char*) { w_.bytes(b ? *b : std::string()); }
  // Whether an optional part follows (one byte, 0 or 1): returns `present`.
  bool present(bool present, const char*) {
    w_.u8(present);
    return present;
  }
  // Whether the form goes on (a part later versions added): always.
  bool more() const { return true; }
  void version(std::uint16_t newest, const char*) { w_.u16(version_ = newest); }
  // A form whose later versions add fields: `written` (the oldest version that holds the value) is
  // written, and is what form_version() says while the fields are written.
  void version(std::uint16_t, std::uint16_t written, const char*) { w_.u16(version_ = written); }
  std::uint16_t form_version() const { return version_; }

  // A list's length as a u32 (a reader refuses over `max`, or more than the bytes left could hold
  // at `record_bytes` an item, and sizes the list): returns it.
  template <class List>
  std::size_t count(const List& items, std::size_t, std::size_t, const char*) {
    w_.u32(static_cast<std::uint32_t>(items.size()));
    return items.size();
  }
  // A list that goes with one counted before it (a reader sizes it to `n`).
  template <class List>
  void resize(const List&, std::size_t) {}
  // A list: its count, then each item's fields.
  template <class List, class Each>
  void list(const List& items, std::size_t max, std::size_t record_bytes, const char* field, Each&& each) {
    count(items, max, record_bytes, field);
    for (const auto& item : items) each(item);
  }
  // A map, the same way: its size, then each key's and value's fields.
  template <class Map, class Each>
  void entries(const Map& map, std::size_t, std::size_t, const char*, Each&& each) {
    w_.u32(static_cast<std::uint32_t>(map.size()));
    for (const auto& [key, value] : map) each(key, value);
  }
  // A variant: the tag of its alternative (tags[index]), then that alternative's fields.
  template <class Variant, std::size_t N, class Each>
  void variant(const Variant& v, const std::array<std::uint8_t, N>& tags, const char*, Each&& each) {
    static_assert(N == std::variant_size_v<Variant>, "a tag for every alternative");
    w_.u8(tags[v.index()]);
    std::visit([&](const auto& alternative) { each(alternative); }, v);
  }

  template <class Ok, class Problem>
  void require(const Ok&, const Problem&) {}
  template <class Value>
  void validate(const Value&, const char*) {}
  void end(const char* = "") {}

  std::string take() { return w_.take(); }

 private:
  ByteWriter w_;
  std::uint16_t version_ = 0;
};

class ReadArchive {
 public:
  static constexpr bool reading = true;

  // `what`: the form, as errors name it ("heartbeat", "operation").
  ReadArchive(std::string_view bytes, std::string what) : r_(bytes, std::move(what)) {}

  void u8(std::uint8_t& v) { v = r_.u8(); }
  void u16(std::uint16_t& v) { v = r_.u16(); }
  void u32(std::uint32_t& v) { v = r_.u32(); }
  void u64(std::uint64_t& v) { v = r_.u64(); }
  void i32(std::int32_t& v) { v = r_.i32(); }
  template <class I>
  void i64(I& v) {
    static_assert(std::is_integral_v<I> && std::is_signed_v<I> && sizeof(I) == 8);
    v = static_cast<I>(r_.i64());
  }
  void f64(double& v) { v = r_.f64(); }
  void finite(double& v, const char* field) { v = r_.finite(field); }
  void vec2(Vec2& v, const char* field) { v = r_.vec2(field); }
  void vec3(Vec3& v, const char* field) { v = r_.vec3(field); }
  void quaternion(Eigen::Quaterniond& q, const char* field) {
    const double w = r_.finite(field), x = r_.finite(field), y = r_.finite(field), z = r_.finite(field);
    q = Eigen::Quaterniond(w, x, y, z);
  }
  void boolean(bool& b, const char* field) { b = r_.boolean(field); }
  template <class I>
  void index(I& v, std::size_t n, const char* problem) {
    const std::uint32_t c = r_.u32();
    if (c >= n) r_.fail(problem);
    v = static_cast<I>(c);
  }
  // An enum of one byte, refused past `last` with `problem`.
  template <class E>
  void enumeration(E& e, E last, const char* problem) {
    const std::uint8_t v = r_.u8();
    if (v > static_cast<std::uint8_t>(last)) r_.fail(problem);
    e = static_cast<E>(v);
  }
  // A byte of flags, refused with `problem` if a bit beyond them is set.
  template <class... B>
  void flags(const char* problem, B&... bits) {
    const std::uint8_t packed = r_.u8();
    if (packed >> sizeof...(B)) r_.fail(problem);
    int bit = 0;
    ((bits = ((packed >> bit) & 1) != 0, ++bit), ...);
  }
  void str(std::string& s, std::size_t max, const char* field) { s = r_.str(limit(max), field); }
  void bytes(std::string& s, std::size_t max, const char* field) { s = std::string(r_.bytes(limit(max), field)); }
  template <class Bytes>
  void raw(Bytes& b, std::size_t n) {
    const std::string_view in = r_.take(n);
    b.assign(in.begin(), in.end());
  }
  void shared_bytes(std::shared_ptr<const std::string>& b, const char* field) {
    b = std::make_shared<const std::string>(r_.bytes(r_.left(), field));
  }
  bool present(bool, const char* field) { return r_.boolean(field); }
  bool more() const { return !r_.at_end(); }
  void version(std::uint16_t newest, const char* what) { version_ = check_format_version(r_, newest, what); }
  void version(std::uint16_t newest, std::uint16_t, const char* what) { version(newest, what); }
  // The version the form was written in (what fields a later version added are there).
  std::uint16_t form_version() const { return version_; }

  template <class List>
  std::size_t count(List& items, std::size_t max, std::size_t record_bytes, const char* field) {
    items.resize(r_.count(max, record_bytes, field));
    return items.size();
  }
  template <class List>
  void resize(List& items, std::size_t n) {
    items.resize(n);
  }
  // A set (a list without resize) keeps each value once.
  template <class List, class Each>
  void list(List& items, std::size_t max, std::size_t record_bytes, const char* field, Each&& each) {
    if constexpr (has_resize<List>::value) {
      count(items, max, record_bytes, field);
      for (auto& item : items) each(item);
    } else {
      const std::size_t n = r_.count(max, record_bytes, field);
      for (std::size_t i = 0; i < n; ++i) {
        typename List::value_type item{};
        each(item);
        items.insert(items.end(), std::move(item));
      }
    }
  }
  // A key read twice keeps its last value.
  template <class Map, class Each>
  void entries(Map& map, std::size_t max, std::size_t record_bytes, const char* field, Each&& each) {
    const std::size_t n = r_.count(max, record_bytes, field);
    for (std::size_t i = 0; i < n; ++i) {
      typename Map::key_type key{};
      typename Map::mapped_type value{};
      each(key, value);
      map[std::move(key)] = std::move(value);
    }
  }
  template <class Variant, std::size_t N, class Each>
  void variant(Variant& v, const std::array<std::uint8_t, N>& tags, const char* problem, Each&& each) {
    static_assert(N == std::variant_size_v<Variant>, "a tag for every alternative");
    const std::uint8_t tag = r_.u8();
    std::size_t index = 0;
    while (index < N && tags[index] != tag) ++index;
    if (index == N) r_.fail(problem);
    emplace(v, index, std::make_index_sequence<N>());
    std::visit([&](auto& alternative) { each(alternative); }, v);
  }

  // Fails with `problem` (a message, or a function that makes it) unless `ok`.
  template <class Problem>
  void require(bool ok, const Problem& problem) {
    if (ok) return;
    if constexpr (std::is_invocable_v<const Problem&>) r_.fail(problem());
    else r_.fail(problem);
  }
  // The value's own validate(), its InputError said after `prefix`.
  template <class Value>
  void validate(const Value& value, const char* prefix) {
    try {
      value.validate();
    } catch (const InputError& e) {
      r_.fail(prefix + std::string(e.what()));
    }
  }
  // Nothing may follow the form.
  void end(const char* after = "") {
    if (!r_.at_end()) r_.fail(std::to_string(r_.left()) + " bytes are left over" + after);
  }

 private:
  template <class List, class = void>
  struct has_resize : std::false_type {};
  template <class List>
  struct has_resize<List, std::void_t<decltype(std::declval<List&>().resize(0))>> : std::true_type {};
  std::size_t limit(std::size_t max) const { return max == kToTheEnd ? r_.left() : max; }
  template <class Variant, std::size_t... I>
  static void emplace(Variant& v, std::size_t index, std::index_sequence<I...>) {
    ((index == I ? (void)v.template emplace<I>() : void()), ...);
  }
  ByteReader r_;
  std::uint16_t version_ = 0;
};

// A value's binary form, and a value read from one (`what` names the form in errors).
template <class T, class... Extra>
std::string write_form(const T& value, const Extra&... extra) {
  WriteArchive a;
  fields(a, value, extra...);
  return a.take();
}
template <class T, class... Extra>
T read_form(std::string_view bytes, const char* what, const Extra&... extra) {
  ReadArchive a(bytes, what);
  T value{};
  fields(a, value, extra...);
  return value;
}

}  // namespace kiji::detail
