// Reading an imported file's bytes (importers/src/read_file.cpp): the bytes as they are, and each
// refusal at its place: a missing file where it was named (or at itself), a directory, a file
// over the format's limit, one that may not be read, binary data.
#include "read_file.h"

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <string>

#include "test_util.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;

using testing::ErrorOf;

TEST_CASE("read file: the bytes, or why not, at the file or where it was named", "[importers]") {
  const fs::path dir = fs::temp_directory_path() / "cfuse_read_file_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  auto write = [&](const char* name, const std::string& bytes) {
    std::ofstream(dir / name, std::ios::binary) << bytes;
    return (dir / name).string();
  };
  const size_t limit = 1 << 20;
  // Any bytes but NUL, as they are: line ends and all.
  const std::string head = "V1\r\n# caf\xE9\n";
  const std::string text = head + std::string(limit - head.size(), 'x');  // at the limit
  CHECK(ReadImportedFile(write("ok.cao", text), {}, "CAO", limit) == text);
  CHECK(ReadImportedFile(write("empty.cao", ""), {}, "CAO", limit).empty());

  const std::string missing = (dir / "missing.urdf").string();
  InputError e = ErrorOf([&] { ReadImportedFile(missing, {}, "URDF", limit); });
  CHECK(e.where().ToString() == missing);
  CHECK(e.message() == "cannot open: no such file");
  e = ErrorOf([&] { ReadImportedFile(missing, SourceLocation("m.yaml", 3, 10), "URDF", limit); });
  CHECK(e.where().ToString() == "m.yaml:3:10");
  CHECK(e.message() == "cannot open '" + missing + "': no such file");

  e = ErrorOf([&] { ReadImportedFile(dir.string(), {}, "URDF", limit); });
  CHECK(e.where().ToString() == dir.string());
  CHECK(e.message() == "is a directory, not a URDF file");

  const std::string big = write("big.cao", text + "x");
  e = ErrorOf([&] { ReadImportedFile(big, {}, "CAO", limit); });
  CHECK(e.where().ToString() == big);
  CHECK(e.message() == "file is larger than the 1 MiB limit for CAO files");

  const std::string binary = write("binary.urdf", std::string("<robot>\0</robot>", 16));
  e = ErrorOf([&] { ReadImportedFile(binary, {}, "URDF", limit); });
  CHECK(e.where().ToString() == binary);
  CHECK(e.message() == "not a URDF file: it holds binary data");

  const std::string locked = write("locked.cao", "V1\n");
  fs::permissions(locked, fs::perms::none);
  if (!std::ifstream(locked)) {  // root reads it anyway
    e = ErrorOf([&] { ReadImportedFile(locked, {}, "CAO", limit); });
    CHECK(e.where().ToString() == locked);
    CHECK(e.message() == "cannot open: Permission denied");
  }
  fs::permissions(locked, fs::perms::owner_all);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace cfuse
