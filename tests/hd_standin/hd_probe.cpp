// Opens a Phantom with the default options (the library found on the loader's path) and says what
// it opened: test_phantom runs it with the stand-in's folder on LD_LIBRARY_PATH.
#include "kiji/phantom.h"

#include <cstdio>

int main() {
  try {
    kiji::PhantomDevice device;
    std::printf("opened %s from %s\n", device.info().model.c_str(), device.info().library.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
}
