// ROS1 bags through a module of their own (libctcal_ros1.so: ros1_bag.cpp, ros1_bag_writer.cpp),
// loaded when a ROS1 bag is first opened or written.
//
// Why a module: librosbag_storage brings ~18 shared libraries (roslib, rospack and through it
// libpython, class_loader, boost_filesystem, console_bridge, ...), which the dynamic loader maps
// and relocates at every start of every ctcal command, ~10 ms each time on the 2-core machine,
// twice for `calibrate` (it re-executes itself for the huge-page heap), whether or not the data
// is a bag. The module is found where the build put it (CTCAL_ROS1_MODULE), else next to the
// running program.
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "ctcal/sensors/ros_bag.h"
#include "loaded_library.h"

#ifndef CTCAL_ROS1_MODULE
#error "CTCAL_ROS1_MODULE (the ROS1 module's path) is set by sensors/CMakeLists.txt"
#endif

namespace ctcal {

namespace {

struct Ros1Module {
  RosBagReader* (*open_bag)(const std::string& path);
  void* (*writer_open)(const std::string& path, int compression);
  void (*writer_write)(void* writer, const std::string& topic, const std::string& type,
                       std::int64_t t_ns, const std::vector<std::uint8_t>& bytes);
  void (*writer_close)(void* writer);
  void (*writer_free)(void* writer);
};

Ros1Module Load() {
  namespace fs = std::filesystem;
  std::vector<std::string> candidates = {CTCAL_ROS1_MODULE};
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  const std::string beside =
      ec ? std::string() : (self.parent_path() / fs::path(CTCAL_ROS1_MODULE).filename()).string();
  if (!beside.empty() && beside != candidates.front())
    candidates.push_back(beside);
  void* module = nullptr;
  std::string tried, path;
  for (const std::string& candidate : candidates) {
    if (!fs::exists(candidate, ec)) {
      tried += (tried.empty() ? "" : ", ") + candidate + " (absent)";
      continue;
    }
    // RTLD_LOCAL: librosbag's symbols stay out of the global namespace; never closed.
    module = dlopen(candidate.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (module != nullptr) {
      path = candidate;
      break;
    }
    tried += (tried.empty() ? "" : ", ") + candidate + " (" + internal::LoaderError() + ")";
  }
  if (module == nullptr)
    throw std::runtime_error("ROS1 bags need ctcal's ROS1 module, which cannot be loaded: " +
                             tried + " (build it with the program: make)");
  const std::string owner = "the ROS1 bag module " + path;
  Ros1Module m{};
  internal::ResolveFunction(module, owner, "ctcal_ros1_open_bag", &m.open_bag);
  internal::ResolveFunction(module, owner, "ctcal_ros1_writer_open", &m.writer_open);
  internal::ResolveFunction(module, owner, "ctcal_ros1_writer_write", &m.writer_write);
  internal::ResolveFunction(module, owner, "ctcal_ros1_writer_close", &m.writer_close);
  internal::ResolveFunction(module, owner, "ctcal_ros1_writer_free", &m.writer_free);
  return m;
}

const Ros1Module& Ros1() {
  static const Ros1Module module = Load();
  return module;
}

}  // namespace

std::unique_ptr<RosBagReader> OpenRos1Bag(const std::string& path) {
  return std::unique_ptr<RosBagReader>(Ros1().open_bag(path));
}

struct Ros1BagWriter::Impl {
  void* writer = nullptr;
};

Ros1BagWriter::Ros1BagWriter(const std::string& path, RosBagCompression compression)
    : impl_(std::make_unique<Impl>()) {
  impl_->writer = Ros1().writer_open(path, static_cast<int>(compression));
}

Ros1BagWriter::~Ros1BagWriter() {
  if (!impl_->writer)
    return;
  try {
    Ros1().writer_close(impl_->writer);
  } catch (const std::exception&) {
    // Close() reports it when called; a destructor cannot.
  }
  Ros1().writer_free(impl_->writer);
}

void Ros1BagWriter::Write(const std::string& topic, const std::string& type, std::int64_t t_ns,
                          const std::vector<std::uint8_t>& bytes) {
  Ros1().writer_write(impl_->writer, topic, type, t_ns, bytes);
}

void Ros1BagWriter::Close() {
  Ros1().writer_close(impl_->writer);
}

}  // namespace ctcal
