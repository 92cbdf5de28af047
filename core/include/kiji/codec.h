// The binary forms of garments and bodies: a garment's or a body's whole state as bytes, exactly
// (doubles bit for bit), with decoders that check every length before they allocate. Operations,
// session files, peers and the child process that reads a model file all carry these.
#pragma once

#include "kiji/body.h"
#include "kiji/garment.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace kiji {

// Version of the garment and body binary forms (an operation's own is kOperationVersion); a decoder
// refuses a later one, naming both.
constexpr std::uint16_t kOperationFormatVersion = 1;

// Limits a decoder enforces on outside bytes (a file, a network message) before allocating.
struct DecodeLimits {
  std::size_t max_vertices = 4'000'000;
  std::size_t max_faces = 8'000'000;
  std::size_t max_texture_side = 16384;
  std::size_t max_string = 4096;
  std::size_t max_params = 256;
  // The world's bounds: how far from the origin, along each axis, a pointer (a tool event's position
  // and ray) or a solver's local centre may be, in metres. A person designs within a room; a
  // kilometre leaves room to spare, and a value past it is damage, not a design.
  double world_extent = 1000;
};

// A garment's whole state (mesh with every property, material, texture, tacks, where its cloth
// sleeps: Garment::sleep_record, and what its solver carries to the next step: Garment::step_record,
// where it has one), exactly: doubles are kept bit for bit, and vertex indices (holes included) are
// kept. Bytes written before the sleep record was part of them decode, awake; those written before
// the step record, with none.
std::string encode_garment(const Garment& garment);
Garment decode_garment(std::string_view bytes, const DecodeLimits& limits = {});

// A body's geometry and name.
std::string encode_body(const Body& body);
Body decode_body(std::string_view bytes, const DecodeLimits& limits = {});

// A 64-bit FNV-1a hash of bytes: names payloads and states (not a security measure).
std::uint64_t hash_bytes(std::string_view bytes, std::uint64_t seed = 0xcbf29ce484222325ull);

}  // namespace kiji
