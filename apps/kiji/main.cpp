// kiji: the command line.
#include <cstdio>

int main(int argc, char** argv) {
  std::fprintf(stderr, "usage: kiji drape [options]\n");
  return 2;
}
