#include "mrcal_api.h"

#include <dlfcn.h>

#include <stdexcept>
#include <string>

#ifndef CTCAL_MRCAL_SONAME
#error "CTCAL_MRCAL_SONAME (libmrcal's soname) is set by cmake/CtcalDependencies.cmake"
#endif

namespace ctcal::internal {

namespace {

std::string LoaderError() {
  const char* e = dlerror();
  return e != nullptr ? e : "unknown error";
}

template <typename F>
void Resolve(void* library, const char* name, F* f) {
  void* symbol = dlsym(library, name);
  if (symbol == nullptr)
    throw std::runtime_error(std::string("libmrcal (") + CTCAL_MRCAL_SONAME + ") has no " + name +
                             ": " + LoaderError());
  *f = reinterpret_cast<F>(symbol);
}

MrcalApi Load() {
  // RTLD_LOCAL: its symbols stay out of the global namespace (only dlsym finds them); never
  // closed, the functions are used until the process ends.
  void* library = dlopen(CTCAL_MRCAL_SONAME, RTLD_NOW | RTLD_LOCAL);
  if (library == nullptr)
    throw std::runtime_error(std::string("mrcal lens models need libmrcal (") + CTCAL_MRCAL_SONAME +
                             "), which cannot be loaded: " + LoaderError() +
                             " (install Debian's libmrcal: scripts/install_deps.sh)");
  MrcalApi api{};
  Resolve(library, "mrcal_supported_lensmodel_names", &api.supported_lensmodel_names);
  Resolve(library, "mrcal_lensmodel_name", &api.lensmodel_name);
  Resolve(library, "mrcal_lensmodel_num_params", &api.lensmodel_num_params);
  Resolve(library, "mrcal_lensmodel_from_name", &api.lensmodel_from_name);
  Resolve(library, "mrcal_lensmodel_type_from_name", &api.lensmodel_type_from_name);
  Resolve(library, "mrcal_knots_for_splined_models", &api.knots_for_splined_models);
  Resolve(library, "mrcal_lensmodel_metadata", &api.lensmodel_metadata);
  Resolve(library, "mrcal_project", &api.project);
  Resolve(library, "mrcal_unproject", &api.unproject);
  return api;
}

}  // namespace

const MrcalApi& Mrcal() {
  static const MrcalApi api = Load();
  return api;
}

}  // namespace ctcal::internal
