// Output files a reader never sees half-written: the content goes to a temporary file beside the
// target (".NAME.part.EXT": hidden, so `ls` and shell globs skip it), which then replaces the
// target with one rename (atomic on POSIX within one filesystem). A program watching the output
// folder (a live viewer of a followed run) sees either the old file or the complete new one.
#pragma once

#include <functional>
#include <ostream>
#include <string>

namespace fsp {

// The temporary name for PATH: DIR/.STEM.part.EXT (the extension kept, so writers that choose a
// format by it, such as cv::VideoWriter, still work).
std::string PartPath(const std::string& path);

// Renames PART over PATH; throws InputError naming PATH when the rename fails (PART is removed).
void CommitPart(const std::string& part, const std::string& path);

// Writes PATH atomically: WRITE fills a stream on PartPath(PATH), which is then renamed over PATH.
// Throws InputError ("PATH: cannot write WHAT" / "PATH: error while writing WHAT") when the file
// cannot be written; the temporary file is removed then and PATH is left as it was.
void WriteFileAtomically(const std::string& path, const std::string& what,
                         const std::function<void(std::ostream&)>& write);

}  // namespace fsp
