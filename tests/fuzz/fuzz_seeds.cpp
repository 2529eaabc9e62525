// fuzz_seeds DIR: writes the seed corpora of the fuzz targets (fuzz_seeds.h) into DIR/<target>
// (npz, rawlog, graph, ground_truth, python_snapshot), after checking that the readers of this
// build read every seed back (exit 1 if not). scripts/fuzz.sh runs it before fuzzing.
#include <filesystem>
#include <fstream>
#include <iostream>

#include "fuzz_seeds.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: fuzz_seeds DIR\n";
    return 2;
  }
  namespace fs = std::filesystem;
  for (const auto& [target, corpus] :
       {std::pair{std::string("npz"), dbacov::fuzz::npzSeeds()},
        std::pair{std::string("rawlog"), dbacov::fuzz::rawlogSeeds()},
        std::pair{std::string("graph"), dbacov::fuzz::graphSeeds()},
        std::pair{std::string("ground_truth"), dbacov::fuzz::groundTruthSeeds()},
        std::pair{std::string("python_snapshot"), dbacov::fuzz::pythonSnapshotSeeds()}}) {
    const fs::path dir = fs::path(argv[1]) / target;
    fs::create_directories(dir);
    for (const auto& [name, bytes] : corpus) {
      int snapshots = 0;
      try {
        snapshots = dbacov::fuzz::itemsInSeed(target, name, bytes);
      } catch (const std::exception& e) {
        std::cerr << "fuzz_seeds: this build cannot read its own seed: " << e.what() << "\n";
        return 1;
      }
      if (snapshots == 0) {
        std::cerr << "fuzz_seeds: seed " << name << " holds nothing the reader reads\n";
        return 1;
      }
      std::ofstream(dir / ("seed_" + name), std::ios::binary)
          .write(reinterpret_cast<const char*>(bytes.data()),
                 static_cast<std::streamsize>(bytes.size()));
    }
    std::cout << "fuzz_seeds: " << corpus.size() << " seeds in " << dir.string() << "\n";
  }
  return 0;
}
