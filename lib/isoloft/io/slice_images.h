// @file io/slice_images.h
// @brief A directory of PNGs (or a file list) as a SliceStack, slice k at z = k.
#pragma once

#include <string>
#include <vector>

#include "isoloft/core/slice_stack.h"

namespace isoloft {

/// A single directory's *.png (hidden skipped) in natural order, else the inputs.
/// \throw InputError for no inputs, a missing file, a directory among other
///        inputs, or a directory without PNGs.
std::vector<std::string> list_slice_files(const std::vector<std::string>& inputs);

/// Reads the slices in parallel: raw values, source = file, z = k, max_value
/// the largest of the slices', pixel_size 1.
/// \throw InputError naming the file if a slice is unreadable, differs in size
///        from the first, or mixes grayscale with colour or 8 with 16 bit.
SliceStack read_slice_images(const std::vector<std::string>& files);

/// As read_slice_images() from the PNG headers alone: the images are decoded
/// on demand (SliceStack::load_image).
/// \throw InputError as read_slice_images() for the headers; load_image
///        throws it naming the file for corrupt pixel data or a file changed
///        since.
SliceStack open_slice_images(const std::vector<std::string>& files);

namespace detail {
/// Digit runs by value ("a2" < "a10"), the rest case-insensitively; total.
bool natural_less(const std::string& a, const std::string& b);
}  // namespace detail

}  // namespace isoloft
