#include "isoloft/io/slice_images.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cctype>
#include <exception>
#include <filesystem>

#include "isoloft/core/error.h"
#include "isoloft/io/file_util.h"
#include "isoloft/io/png.h"

namespace isoloft {

namespace fs = std::filesystem;

namespace detail {

bool natural_less(const std::string& a, const std::string& b) {
  std::size_t i = 0, j = 0;
  auto digit = [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; };
  while (i < a.size() && j < b.size()) {
    if (digit(a[i]) && digit(b[j])) {
      // Compare digit runs by value without overflow: skip leading zeros,
      // then a longer run is larger, else compare lexicographically.
      std::size_t i0 = i, j0 = j;
      while (i0 < a.size() && a[i0] == '0') ++i0;
      while (j0 < b.size() && b[j0] == '0') ++j0;
      std::size_t i1 = i0, j1 = j0;
      while (i1 < a.size() && digit(a[i1])) ++i1;
      while (j1 < b.size() && digit(b[j1])) ++j1;
      const std::size_t la = i1 - i0, lb = j1 - j0;
      if (la != lb) return la < lb;
      const int c = a.compare(i0, la, b, j0, lb);
      if (c != 0) return c < 0;
      i = i1;
      j = j1;
    } else {
      const int ca = std::tolower(static_cast<unsigned char>(a[i]));
      const int cb = std::tolower(static_cast<unsigned char>(b[j]));
      if (ca != cb) return ca < cb;
      ++i;
      ++j;
    }
  }
  if ((a.size() - i) != (b.size() - j)) return (a.size() - i) < (b.size() - j);
  return a < b;  // e.g. "a01" vs "a1": equal by value, keep a total order
}

}  // namespace detail

namespace {
bool has_png_extension(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext == ".png";
}
}  // namespace

std::vector<std::string> list_slice_files(const std::vector<std::string>& inputs) {
  if (inputs.empty()) throw InputError("", "no input slices given");
  std::error_code ec;
  if (inputs.size() == 1 && fs::is_directory(inputs[0], ec)) {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(inputs[0], ec)) {
      const fs::path& p = entry.path();
      const std::string name = p.filename().string();
      if (name.empty() || name[0] == '.') continue;  // hidden, e.g. our own atomic temp files
      if (!has_png_extension(p)) continue;
      std::error_code dir_ec;
      if (entry.is_directory(dir_ec)) continue;  // a folder named x.png is not a slice
      // Any other .png that is not a regular file (a broken link, a FIFO, a
      // device) is an error wherever it sorts, never skipped.
      detail::check_regular_file(p.string());
      names.push_back(name);
    }
    if (ec) throw InputError(inputs[0], "cannot list directory (" + ec.message() + ")");
    if (names.empty()) throw InputError(inputs[0], "directory contains no .png files");
    std::sort(names.begin(), names.end(), detail::natural_less);
    std::vector<std::string> files;
    files.reserve(names.size());
    for (const auto& n : names) files.push_back((fs::path(inputs[0]) / n).string());
    return files;
  }
  for (const auto& f : inputs) {
    if (fs::is_directory(f, ec))
      throw InputError(f, "a directory must be the only input (got " + std::to_string(inputs.size()) + " inputs)");
    detail::check_regular_file(f);  // missing, a FIFO or a device: refused before it is opened
  }
  return inputs;
}

namespace {

// read(file) of every file in parallel; the first failing slice in order is reported.
template <class Read>
auto read_all(const std::vector<std::string>& files, Read read) {
  if (files.empty()) throw InputError("", "no input slices given");
  const std::size_t n = files.size();
  std::vector<decltype(read(files[0]))> out(n);
  std::vector<std::exception_ptr> errors(n);
  tbb::parallel_for(std::size_t(0), n, [&](std::size_t k) {
    try {
      out[k] = read(files[k]);
    } catch (...) {
      errors[k] = std::current_exception();
    }
  });
  // Report the first failing slice in order, independent of thread timing.
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
  return out;
}

// The stack of these headers (sizes and bit depths checked), images empty.
SliceStack stack_of(const std::vector<std::string>& files, const std::vector<PngInfo>& info) {
  SliceStack stack;
  stack.width = info[0].width;
  stack.height = info[0].height;
  stack.max_value = 0;
  stack.pixel_size = 1.0;
  stack.slices.resize(files.size());
  const bool color0 = info[0].color();
  for (std::size_t k = 0; k < files.size(); ++k) {
    const PngInfo& im = info[k];
    if (im.width != stack.width || im.height != stack.height)
      throw InputError(files[k], std::to_string(im.width) + "x" + std::to_string(im.height) + ", expected " +
                                     std::to_string(stack.width) + "x" + std::to_string(stack.height) + " like " + files[0]);
    if (im.color() != color0)
      throw InputError(files[k], std::string(im.color() ? "colour" : "grayscale") + " image, expected " +
                                     (color0 ? "colour" : "grayscale") + " like " + files[0]);
    // Mixed 8/16-bit gray would put "white" (> half range) at different
    // levels in different slices, so it is rejected like mixed colour.
    if (!im.color() && im.max_value != info[0].max_value)
      throw InputError(files[k], std::string(im.max_value == 65535u ? "16" : "8") + "-bit grayscale, expected " +
                                     (info[0].max_value == 65535u ? "16" : "8") + "-bit like " + files[0]);
    stack.max_value = std::max(stack.max_value, im.max_value);
    stack.slices[k].source = files[k];
    stack.slices[k].z = double(k);
  }
  return stack;
}

PngInfo info_of(const RawImage& im) { return {im.values.width, im.values.height, im.max_value}; }

}  // namespace

SliceStack read_slice_images(const std::vector<std::string>& files) {
  std::vector<RawImage> images = read_all(files, read_png);
  std::vector<PngInfo> info;
  for (const auto& im : images) info.push_back(info_of(im));
  SliceStack stack = stack_of(files, info);
  for (std::size_t k = 0; k < files.size(); ++k) stack.slices[k].image = std::move(images[k].values);
  return stack;
}

SliceStack open_slice_images(const std::vector<std::string>& files) {
  const std::vector<PngInfo> info = read_all(files, read_png_info);
  SliceStack stack = stack_of(files, info);
  stack.load_image = [files, info](std::size_t k) {
    RawImage im = read_png(files[k]);
    const PngInfo now = info_of(im);
    if (now.width != info[k].width || now.height != info[k].height || now.max_value != info[k].max_value)
      throw InputError(files[k], "the file changed while it was being read (its header differs)");
    return std::move(im.values);
  };
  return stack;
}

}  // namespace isoloft
