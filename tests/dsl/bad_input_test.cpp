#include <catch2/catch.hpp>
#include <filesystem>
#include <iostream>
#include "dsl/model_loader.h"
#include "test_util.h"
namespace fs = std::filesystem;
TEST_CASE("bad input: dump") {
  std::vector<std::string> files;
  for (auto& e : fs::directory_iterator(std::getenv("BADDIR") ? std::getenv("BADDIR") : "tests/data/bad")) files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  files.push_back("tests/data/bad/nothere.yaml");
  for (auto& f : files) {
    try { cfuse::dsl::LoadModel(f); std::cout << f << ": LOADED\n"; }
    catch (const cfuse::InputError& e) { std::cout << e.what() << "\n"; }
    catch (const std::exception& e) { std::cout << f << ": OTHER " << e.what() << "\n"; }
  }
}
