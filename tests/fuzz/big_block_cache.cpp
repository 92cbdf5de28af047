// One 16 MiB block kept between inputs for the assimp targets: assimp's OBJ reader allocates its
// line cache (IOStreamBuffer, 4096 x 4096 bytes) for every file whatever its size, and under
// AddressSanitizer each such allocation is a fresh mmap whose pages fault in one by one, which
// made those targets spend nearly all their time in the kernel. The block is poisoned while it is
// kept, so a use after free still reports (as use-after-poison); its redzones are the allocator's.
// Every other allocation goes to the sanitizer runtime's own operator new and delete unchanged.
#include <dlfcn.h>
#include <sanitizer/asan_interface.h>

#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <new>

namespace {

constexpr std::size_t kBlockSize = 4096 * 4096;

using NewFn = void* (*)(std::size_t);
using DeleteFn = void (*)(void*);
using SizedDeleteFn = void (*)(void*, std::size_t);

// The runtime's operator new and delete, looked up in the runtime itself: this file's definitions
// come first in the executable, and libstdc++'s, next in the search order, would skip the
// runtime's new/delete mismatch checks.
template <typename Fn>
Fn runtime_symbol(const char* name) {
  static void* runtime = [] {
    void* h = dlopen("libclang_rt.asan-x86_64.so", RTLD_NOW | RTLD_NOLOAD);
    if (h == nullptr) {
      std::fprintf(stderr, "big_block_cache: the shared ASan runtime is not loaded (%s)\n", dlerror());
      std::abort();
    }
    return h;
  }();
  void* f = dlsym(runtime, name);
  if (f == nullptr) {
    std::fprintf(stderr, "big_block_cache: %s is missing from the ASan runtime\n", name);
    std::abort();
  }
  return reinterpret_cast<Fn>(f);
}

void* block = nullptr;
bool block_in_use = false;

void* allocate(std::size_t size, const char* name) {
  if (size == kBlockSize && block != nullptr && !block_in_use) {
    block_in_use = true;
    ASAN_UNPOISON_MEMORY_REGION(block, kBlockSize);
    // As a fresh allocation holds it where a fuzz input reaches (ASan's fill of 4 KiB, then the
    // zeros of new pages): what assimp reads past its data is then the same when one input is
    // replayed alone, not what the input before left.
    std::memset(block, 0xbe, 4096);
    std::memset(static_cast<char*>(block) + 4096, 0, std::size_t(128) << 10);
    return block;
  }
  void* p = runtime_symbol<NewFn>(name)(size);
  if (size == kBlockSize && block == nullptr) {
    block = p;
    block_in_use = true;
  }
  return p;
}

bool keep(void* p) {
  if (p == nullptr || p != block) return false;
  block_in_use = false;
  ASAN_POISON_MEMORY_REGION(block, kBlockSize);
  return true;
}

}  // namespace

void* operator new(std::size_t size) { return allocate(size, "_Znwm"); }
void* operator new[](std::size_t size) { return allocate(size, "_Znam"); }
void operator delete(void* p) noexcept {
  if (!keep(p)) runtime_symbol<DeleteFn>("_ZdlPv")(p);
}
void operator delete[](void* p) noexcept {
  if (!keep(p)) runtime_symbol<DeleteFn>("_ZdaPv")(p);
}
void operator delete(void* p, std::size_t size) noexcept {
  if (!keep(p)) runtime_symbol<SizedDeleteFn>("_ZdlPvm")(p, size);
}
void operator delete[](void* p, std::size_t size) noexcept {
  if (!keep(p)) runtime_symbol<SizedDeleteFn>("_ZdaPvm")(p, size);
}
