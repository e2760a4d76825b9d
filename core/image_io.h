// Image files: multi-layer OpenEXR (float RGB per layer), tone-mapped sRGB PNG,
// and atomic text files.
//
// Writing: every writer encodes the whole file in memory and hands it to
// writeFileAtomically(), which checks every write, fsyncs, closes and checks,
// and only then renames the temporary file over the target. A full disk or
// any other I/O error leaves an existing target untouched and reports the
// reason. Targets that are not regular files are never replaced: a symlink is
// followed (the file it names is replaced atomically and the link stays), a
// device, FIFO or socket (/dev/null, /dev/stdout) is written through, and a
// directory is refused.
// All functions return an error ("path: reason") on failure.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "core/film.h"
#include "core/result.h"

namespace vsl {

struct Layer {
  std::string name;  // empty = the default layer (channels R, G, B)
  Image image;
};

// Writes size bytes to path as described above. Thread-safe.
Result<void> writeFileAtomically(const std::string& path, const void* data, size_t size);
// The file writeFileAtomically(path) would replace (beside which it writes
// its temporary file): path with its symbolic links followed (dangling ones
// too); empty for a device, FIFO or socket, written through; an error for a
// directory or a link that does not resolve.
Result<std::string> atomicWriteTarget(const std::string& path);

// half: 16-bit channels (relative precision 2^-11; the shipped references,
// whose size matters more than the last digits).
Result<void> writeExr(const std::string& path, const std::vector<Layer>& layers,
                      const std::map<std::string, std::string>& attributes = {}, bool half = false);
// Reads every RGB layer (channels NAME.R/G/B, or R/G/B for the default layer).
// The data window is checked before any allocation: at most 65536 pixels a
// side, and no more decoded bytes than the file could plausibly hold (4096
// times its size, with a 16 MiB floor), so a patched header cannot exhaust
// memory. attributes (optional) receives the header's string attributes.
Result<std::vector<Layer>> readExr(const std::string& path, std::map<std::string, std::string>* attributes = nullptr);

// Tone mapping for display and PNG: linear * 2^exposure, clamped, sRGB-encoded.
uint8_t toSrgb8(float linear);
Result<void> writePng(const std::string& path, const Image& image, float exposure);
// 8-bit RGB pixels as they are.
Result<void> writePngRgb8(const std::string& path, int width, int height, const std::vector<uint8_t>& rgb);
// 8-bit pixels of 1 (grey), 2 (grey, alpha), 3 (RGB) or 4 (RGBA) channels as they are.
Result<void> writePng8(const std::string& path, int width, int height, int channels,
                       const std::vector<uint8_t>& pixels);
Result<void> writeTextFile(const std::string& path, const std::string& text);

}  // namespace vsl
