// Placeholder entry point while the command line is being built.
#include <cstdio>

int main() {
  std::puts("lec: command line under construction");
  return 0;
}
