// What the libraries loaded on demand share (mrcal_api.cpp: libmrcal; ros1_module.cpp: the ROS1
// bag module): the loader's message and a function looked up by name.
#pragma once

#include <dlfcn.h>

#include <stdexcept>
#include <string>

namespace ctcal::internal {

// dlerror()'s message for the last dlopen / dlsym that failed.
inline std::string LoaderError() {
  const char* e = dlerror();
  return e != nullptr ? e : "unknown error";
}

// *f = the function `name` of `library` (a dlopen handle); throws "<owner> has no <name>: <why>".
template <typename F>
void ResolveFunction(void* library, const std::string& owner, const char* name, F* f) {
  void* symbol = dlsym(library, name);
  if (symbol == nullptr)
    throw std::runtime_error(owner + " has no " + name + ": " + LoaderError());
  *f = reinterpret_cast<F>(symbol);
}

}  // namespace ctcal::internal
