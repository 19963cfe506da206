// The fuzz targets' one helper: ctcal's readers take file paths (their errors name the file), so
// each input is written to a file in the process's own temporary folder first.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

namespace ctcal::fuzz {

// Writes `size` bytes to <tmp>/ctcal-fuzz-<pid>/<name> and returns that path.
inline std::string WriteInput(const std::string& name, const std::uint8_t* data, std::size_t size) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("ctcal-fuzz-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

}  // namespace ctcal::fuzz
