// libmrcal's functions that ctcal calls (mrcal_lens.cpp), loaded when a camera first needs them.
//
// Why not linked: libmrcal brings ~17 shared libraries of its own (FreeImage and its image codecs,
// libdogleg), which the dynamic loader maps and relocates at every start of every ctcal command,
// ~10 ms each time on the 2-core machine, twice for `calibrate` (it re-executes itself for the
// huge-page heap), whether or not the rig has an mrcal lens (most have none). Loaded on first use
// instead (dlopen of the soname the build found), once per process.
#pragma once

extern "C" {
#include <mrcal/mrcal.h>
}

namespace ctcal::internal {

struct MrcalApi {
  decltype(&::mrcal_supported_lensmodel_names) supported_lensmodel_names;
  decltype(&::mrcal_lensmodel_name) lensmodel_name;
  decltype(&::mrcal_lensmodel_num_params) lensmodel_num_params;
  decltype(&::mrcal_lensmodel_from_name) lensmodel_from_name;
  decltype(&::mrcal_lensmodel_type_from_name) lensmodel_type_from_name;
  decltype(&::mrcal_knots_for_splined_models) knots_for_splined_models;
  decltype(&::mrcal_lensmodel_metadata) lensmodel_metadata;
  decltype(&::mrcal_project) project;
  decltype(&::mrcal_unproject) unproject;
};

// The functions, libmrcal loaded on the first call (thread-safe). Throws std::runtime_error
// naming the library and what the loader said when it cannot be loaded or lacks a function.
const MrcalApi& Mrcal();

}  // namespace ctcal::internal
