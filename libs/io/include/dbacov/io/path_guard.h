// OutputPlan: every app lists its inputs and outputs before anything is read or written, and
// check() refuses a run that would destroy an input or write two outputs onto one file.
//
// Files are compared by identity, not by name: an existing path by device + inode (after following
// symlinks, so `a/../b`, a hard link or a symlink to an input are all recognised); a path that does
// not exist yet by its resolved location (the real path of its nearest existing ancestor, following
// a dangling symlink to where it would create the file, plus the remaining components). A
// character device (e.g. /dev/null, a terminal) may take several outputs and be an input too: it
// is written in place, nothing is replaced. Directories given as inputs contribute the files they
// hold with the given extension.
//
// Errors: check() throws dbacov::InputError naming the option and path of both sides, e.g.
//   "--csv v.npz is the input -i v.npz (the same file): writing it would destroy the input;
//    choose another output path"
// The apps report it as bad usage (exit 2) before any output is opened.
#pragma once

#include <string>
#include <vector>

#include "dbacov/core/errors.h"

namespace dbacov::io {

class OutputPlan {
 public:
  /// An input file (or a directory of inputs: its files ending in `dir_extension`, e.g. ".npz").
  /// `option` names where it came from ("-i", "--ground-truth"). Empty paths are ignored.
  void input(const std::string& path, const std::string& option,
             const std::string& dir_extension = "");
  /// An output file that the run may write (created or replaced). Empty paths are ignored.
  void output(const std::string& path, const std::string& option);
  /// An output directory whose files are named by the run (--depth-sigma DIR): refused when it is
  /// an input file; files inside it are compared when they are listed with output().
  void outputDirectory(const std::string& path, const std::string& option);

  /// Throws InputError for the first clash: an output that is an input, two outputs on one file,
  /// an output directory that is an input file.
  void check() const;

 private:
  struct Entry {
    std::string path, option;
  };
  std::vector<Entry> inputs_, outputs_, output_dirs_;
};

/// Where writing `path` lands: follows symlinks (also dangling ones, up to 40 hops) to the file
/// that would be created or replaced. Returns `path` itself when it is not a symlink.
std::string resolveOutputTarget(const std::string& path);

}  // namespace dbacov::io
