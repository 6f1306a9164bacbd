// Slice image stacks: a directory of PNGs (or an explicit file list) read into
// a SliceStack, one slice per image at z = 0, 1, 2, ... (pixel units; the
// caller rescales z when the slice spacing differs from the pixel size).
#pragma once

#include <string>
#include <vector>

#include "isoloft/core/slice_stack.h"

namespace isoloft {

/// The slice files named by the command line: if `inputs` is a single
/// directory, its *.png files (extension case-insensitive, hidden files
/// skipped) in natural name order (slice2 < slice10); otherwise the inputs in
/// the order given.
/// \throw InputError if `inputs` is empty, a file is missing, a directory is
/// mixed with other inputs, or the directory holds no PNG.
std::vector<std::string> list_slice_files(const std::vector<std::string>& inputs);

/// Read the PNG slices `files` (in parallel) into a stack: slices[k].image is
/// the raw image (see RawImage), .source the file, .z = k; width/height from
/// the images; max_value the largest of the slices' max_value; pixel_size 1.
/// \throw InputError naming the file if a slice is unreadable, differs in size
/// from the first slice, or mixes grayscale with colour or 8- with 16-bit
/// grayscale (their value ranges differ, so thresholds would disagree).
SliceStack read_slice_images(const std::vector<std::string>& files);

namespace detail {
/// Natural order: runs of digits compare by value ("a2" < "a10"), everything
/// else by character ignoring case; ties broken by plain string order so the
/// order is total.
bool natural_less(const std::string& a, const std::string& b);
}  // namespace detail

}  // namespace isoloft
