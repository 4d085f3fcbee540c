#pragma once
// The OpenVDB part of a cache file, walked byte by byte before OpenVDB reads it. OpenVDB 10 sizes
// what it allocates from the stream (strings, metadata values, attribute lists) and fills it
// before it can notice damage: a forged file declaring a 1.7 GB string made it allocate and fill
// 1.7 GB. The checksum trailer keeps accidental damage away from OpenVDB; this walk keeps forged
// files away, by accepting only the layout dofcache's own writer produces (docs/reliability.md).
//
// Internal to the sequence module (used by cache_file.cpp); it does not include OpenVDB.
#include <cstdint>
#include <string>
#include <string_view>

namespace dofcache::sequence {

// Throws dofcache::Error (one line naming `path`) unless `vdb`, the file without its trailer, is
// laid out as write_cache_file writes it: OpenVDB file format 224; file metadata only of
// dofcache's names and types; one grid "samples", a PointDataGrid (tree 5-4-3) with its usual
// metadata, a uniform-scale transform, a topology ending where its descriptor says the buffers
// begin, and one attribute descriptor of dofcache's ten attributes, the per-leaf point counts of
// which add up to the declared sample count. Every string, count and compressed block is checked
// against the bytes the file has before anything is read for it.
void check_cache_file_layout(const std::string& path, std::string_view vdb);

}  // namespace dofcache::sequence
