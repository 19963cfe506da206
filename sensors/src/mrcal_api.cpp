#include "mrcal_api.h"

#include <stdexcept>
#include <string>

#include "loaded_library.h"

#ifndef CTCAL_MRCAL_SONAME
#error "CTCAL_MRCAL_SONAME (libmrcal's soname) is set by cmake/CtcalDependencies.cmake"
#endif

namespace ctcal::internal {

namespace {

MrcalApi Load() {
  // RTLD_LOCAL: its symbols stay out of the global namespace (only dlsym finds them); never
  // closed, the functions are used until the process ends.
  void* library = dlopen(CTCAL_MRCAL_SONAME, RTLD_NOW | RTLD_LOCAL);
  if (library == nullptr)
    throw std::runtime_error(std::string("mrcal lens models need libmrcal (") + CTCAL_MRCAL_SONAME +
                             "), which cannot be loaded: " + LoaderError() +
                             " (install Debian's libmrcal: scripts/install_deps.sh)");
  const std::string owner = std::string("libmrcal (") + CTCAL_MRCAL_SONAME + ")";
  MrcalApi api{};
  ResolveFunction(library, owner, "mrcal_supported_lensmodel_names",
                  &api.supported_lensmodel_names);
  ResolveFunction(library, owner, "mrcal_lensmodel_name", &api.lensmodel_name);
  ResolveFunction(library, owner, "mrcal_lensmodel_num_params", &api.lensmodel_num_params);
  ResolveFunction(library, owner, "mrcal_lensmodel_from_name", &api.lensmodel_from_name);
  ResolveFunction(library, owner, "mrcal_lensmodel_type_from_name", &api.lensmodel_type_from_name);
  ResolveFunction(library, owner, "mrcal_knots_for_splined_models", &api.knots_for_splined_models);
  ResolveFunction(library, owner, "mrcal_lensmodel_metadata", &api.lensmodel_metadata);
  ResolveFunction(library, owner, "mrcal_project", &api.project);
  ResolveFunction(library, owner, "mrcal_unproject", &api.unproject);
  return api;
}

}  // namespace

const MrcalApi& Mrcal() {
  static const MrcalApi api = Load();
  return api;
}

}  // namespace ctcal::internal
