// LCM log files behind a plain interface. LCM's C++ header declares a namespace `lcm`, which clashes
// with GMP's C++ function lcm() that CGAL's headers bring in, so no file may include both: the code
// that uses LCM lives in files like this one, which include no CGAL. Internal to the core.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

namespace kiji::detail {

class LcmLog {
 public:
  // mode "r", "w" or "a" (append). good() says whether the file opened.
  LcmLog(const std::string& path, const char* mode);
  ~LcmLog();
  LcmLog(const LcmLog&) = delete;
  LcmLog& operator=(const LcmLog&) = delete;
  bool good() const;

  // Appends an event and hands it to the operating system; false if that failed.
  bool write(const std::string& channel, const std::string& data, std::int64_t timestamp_us);
  // Also to the disk itself (fdatasync).
  void sync();

  enum class Read { Event, End, CutOff, Damaged };
  // The next event. Its header is checked against the bytes left in the file before LCM reads it,
  // so a cut-off or damaged event is CutOff/Damaged (with `why`), never a huge allocation. CutOff is
  // an event that starts as one should and ends with the file; `channel` then holds what of its
  // channel name the file has.
  Read next(std::string& channel, std::string& data, std::string& why);
  // Where the last event read ends, and the file's size.
  std::size_t position() const;
  std::size_t file_size() const { return file_size_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::size_t file_size_ = 0;
};

}  // namespace kiji::detail
