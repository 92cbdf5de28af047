// Kiji's exceptions. Every message says what was wrong and what to do about it.
#pragma once

#include <stdexcept>
#include <string>

namespace kiji {

// Base of everything Kiji throws on purpose.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The user's input cannot be used: a missing or unreadable file, an unknown format, a mesh with no
// triangles, NaN coordinates, a parameter out of range. Nothing was changed.
class InputError : public Error {
 public:
  using Error::Error;
};

// A topology edit was refused because its result would not be a valid manifold mesh.
// The garment is left exactly as it was before the call.
class TopologyError : public Error {
 public:
  using Error::Error;
};

// A simulation step could not be taken: it would have left the cloth in a non-finite state (NaN or
// infinity), under forces or pulls too large for its time step. The step was undone: the garment is
// as it was before it, and the next step starts from there.
class SimulationError : public Error {
 public:
  using Error::Error;
};

}  // namespace kiji
