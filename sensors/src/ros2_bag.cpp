// ROS2 bags in rosbag2's sqlite3 storage: a folder with metadata.yaml naming its storage and its
// .db3 files (a split recording has several, read in the listed order), or one .db3 alone. Each
// database has `topics(id, name, type, serialization_format, ...)` and `messages(id, topic_id,
// timestamp, data)`, rows in the order they were recorded. MCAP, rosbag2's other storage, has no
// reader in Debian 12 (no package of `apt-cache search mcap` reads it), so it is refused by name.
#include <sqlite3.h>
#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <filesystem>
#include <map>
#include <stdexcept>
#include <system_error>

#include "ctcal/sensors/ros_bag.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;

// ROS2 names a type package/msg/Name; ctcal compares ROS1's package/Name.
std::string Ros1TypeName(const std::string& type) {
  const std::size_t at = type.find("/msg/");
  return at == std::string::npos ? type : type.substr(0, at) + type.substr(at + 4);
}

std::string UnsupportedStorage(const std::string& storage) {
  return "storage '" + storage +
         "' is not supported (ctcal reads rosbag2's sqlite3 storage; convert it with `ros2 bag "
         "convert` to sqlite3)";
}

class Database {
 public:
  explicit Database(const std::string& path) : path_(path) {
    if (!fs::is_regular_file(path))
      throw std::runtime_error(path + ": no such file");
    if (sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
      const std::string why = db_ ? sqlite3_errmsg(db_) : "cannot open";
      sqlite3_close(db_);
      throw std::runtime_error(path + ": " + why);
    }
    try {
      CheckNotCut();
    } catch (...) {
      sqlite3_close(db_);
      throw;
    }
  }
  ~Database() { sqlite3_close(db_); }
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  // Runs `sql`, calling `row` for each result row.
  void Query(const std::string& sql, const std::function<void(sqlite3_stmt*)>& row) const {
    sqlite3_stmt* stmt = nullptr;
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &stmt, nullptr) != SQLITE_OK)
      throw std::runtime_error(path_ + ": not a rosbag2 sqlite3 database (" + sqlite3_errmsg(db_) +
                               ")");
    int rc;
    try {
      while ((rc = sqlite3_step(stmt)) == SQLITE_ROW)
        row(stmt);
    } catch (...) {
      sqlite3_finalize(stmt);
      throw;
    }
    sqlite3_finalize(stmt);
    if (rc != SQLITE_DONE)
      throw std::runtime_error(path_ + ": " + sqlite3_errmsg(db_));
  }

 private:
  // A database cut short (a recording stopped by a crash, a copy interrupted) is refused whole:
  // SQLite reads what is left, and when the lost pages hold only the index or the last rows, the
  // queries succeed on a silently shorter recording. Its header (page 1, always present when the
  // file is a database at all) counts the pages the file was written with: fewer bytes on disk
  // than page_count x page_size is a cut. (A database in write-ahead mode keeps its newest pages
  // in the -wal file beside it; SQLite counts them in page_count, so that case is left to the
  // queries.)
  void CheckNotCut() const {
    std::int64_t pages = 0, page_size = 0;
    Query("PRAGMA page_count", [&](sqlite3_stmt* s) { pages = sqlite3_column_int64(s, 0); });
    Query("PRAGMA page_size", [&](sqlite3_stmt* s) { page_size = sqlite3_column_int64(s, 0); });
    std::error_code ec;
    const std::uintmax_t size = fs::file_size(path_, ec);
    if (ec || fs::exists(path_ + "-wal"))
      return;
    const auto expected = static_cast<std::uintmax_t>(pages * page_size);
    if (size < expected) {
      throw std::runtime_error(path_ + ": the file has " + std::to_string(size) +
                               " bytes but its database " + std::to_string(expected) +
                               " (the recording was cut short)");
    }
  }

  std::string path_;
  sqlite3* db_ = nullptr;
};

std::string Text(sqlite3_stmt* stmt, int column) {
  const unsigned char* text = sqlite3_column_text(stmt, column);
  return text ? reinterpret_cast<const char*>(text) : "";
}

class Ros2BagReader : public RosBagReader {
 public:
  explicit Ros2BagReader(const std::string& path) : path_(path) {
    if (fs::is_directory(path))
      ReadMetadata();
    else if (fs::path(path).extension() == ".mcap")
      throw std::runtime_error(path + ": " + UnsupportedStorage("mcap"));
    else
      files_.push_back(path);
    // Topic ids are per database; names and types must agree across the files.
    for (const std::string& file : files_) {
      const Database db(file);
      db.Query("SELECT id, name, type, serialization_format FROM topics", [&](sqlite3_stmt* s) {
        const std::string name = Text(s, 1), format = Text(s, 3);
        if (format != "cdr")
          throw std::runtime_error(file + ": topic '" + name + "' is serialized as '" + format +
                                   "' (ctcal reads cdr)");
        types_[name] = Ros1TypeName(Text(s, 2));
      });
      db.Query(
          "SELECT t.name, COUNT(*) FROM messages m JOIN topics t ON m.topic_id = t.id "
          "GROUP BY t.name",
          [&](sqlite3_stmt* s) {
            counts_[Text(s, 0)] += static_cast<std::size_t>(sqlite3_column_int64(s, 1));
          });
    }
  }

  const std::string& path() const override { return path_; }

  std::vector<RosBagTopic> Topics() const override {
    std::vector<RosBagTopic> topics;
    for (const auto& [name, type] : types_) {
      const auto count = counts_.find(name);
      topics.push_back({name, type, count == counts_.end() ? 0 : count->second});
    }
    return topics;
  }

  void Read(const std::set<std::string>& topics,
            const std::function<void(const RosBagMessage&)>& on_message) override {
    for (const std::string& file : files_) {
      const Database db(file);
      std::map<std::int64_t, std::string> names;  // this file's topic ids
      db.Query("SELECT id, name FROM topics", [&](sqlite3_stmt* s) {
        const std::string name = Text(s, 1);
        if (topics.count(name))
          names[sqlite3_column_int64(s, 0)] = name;
      });
      std::string ids;
      for (const auto& [id, name] : names)
        ids += (ids.empty() ? "" : ",") + std::to_string(id);
      if (ids.empty())
        continue;
      // By row id: the order of recording, without sorting the image blobs.
      db.Query("SELECT topic_id, data FROM messages WHERE topic_id IN (" + ids + ") ORDER BY id",
               [&](sqlite3_stmt* s) {
                 const std::string& name = names.at(sqlite3_column_int64(s, 0));
                 RosBagMessage message;
                 message.topic = &name;
                 message.type = &types_.at(name);
                 message.data = static_cast<const std::uint8_t*>(sqlite3_column_blob(s, 1));
                 message.size = static_cast<std::size_t>(sqlite3_column_bytes(s, 1));
                 message.wire = RosWire::kCdr;
                 on_message(message);
               });
    }
  }

 private:
  void ReadMetadata() {
    const std::string meta = (fs::path(path_) / "metadata.yaml").string();
    YAML::Node info;
    try {
      info = YAML::LoadFile(meta)["rosbag2_bagfile_information"];
    } catch (const YAML::Exception& e) {
      throw std::runtime_error(meta + ": " + e.what());
    }
    if (!info || !info.IsMap())
      throw std::runtime_error(meta + ": no rosbag2_bagfile_information");
    try {
      const std::string storage =
          info["storage_identifier"] ? info["storage_identifier"].as<std::string>() : "";
      if (storage != "sqlite3")
        throw std::runtime_error(meta + ": " + UnsupportedStorage(storage));
      const YAML::Node files = info["relative_file_paths"];
      if (!files || !files.IsSequence() || files.size() == 0)
        throw std::runtime_error(meta + ": relative_file_paths lists no database");
      for (const YAML::Node& f : files)
        files_.push_back((fs::path(path_) / f.as<std::string>()).string());
    } catch (const YAML::Exception& e) {
      throw std::runtime_error(meta + ": " + e.what());
    }
  }

  std::string path_;
  std::vector<std::string> files_;
  std::map<std::string, std::string> types_;
  std::map<std::string, std::size_t> counts_;
};

}  // namespace

std::unique_ptr<RosBagReader> OpenRos2Bag(const std::string& path) {
  return std::make_unique<Ros2BagReader>(path);
}

RosBagKind RosBagKindOf(const std::string& path) {
  const fs::path p(path);
  if (fs::is_directory(p))
    return fs::is_regular_file(p / "metadata.yaml") ? RosBagKind::kRos2 : RosBagKind::kNone;
  if (p.extension() == ".bag")
    return RosBagKind::kRos1;
  if (p.extension() == ".db3" || p.extension() == ".mcap")
    return RosBagKind::kRos2;
  return RosBagKind::kNone;
}

std::unique_ptr<RosBagReader> OpenRosBag(const std::string& path) {
  switch (RosBagKindOf(path)) {
    case RosBagKind::kRos1:
      if (!fs::is_regular_file(path))
        throw std::runtime_error(path + ": no such file");
      return OpenRos1Bag(path);
    case RosBagKind::kRos2:
      return OpenRos2Bag(path);
    case RosBagKind::kNone:
      break;
  }
  throw std::runtime_error(path + ": not a ROS bag (.bag, .db3 or a folder with metadata.yaml)");
}

}  // namespace ctcal
