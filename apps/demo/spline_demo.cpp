// Placeholder until the spline library lands (issue 2).
#include <cstdio>
int main() {
  std::puts("spline demo: pending");
  return 0;
}
