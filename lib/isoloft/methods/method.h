// @file methods/method.h
// @brief The seam for reconstruction methods and z schemes.
// Methods come in families. The columns family (methods/columns/) says how
// one slice of one object becomes a signed distance field (paper 2.1-2.3, or
// a baseline; MethodSpec::slice_field), and a z scheme how those fields are
// interpolated between the slices (paper 2.4) into the planes Marching Cubes
// reads; reconstruct() streams them, with the label partition. A family of
// its own (methods/field3d/) gives MethodSpec::reconstruct, the whole run of
// one input (sections in any orientation), which reconstruct() calls instead.
// Each method is one file returning its spec, plus one line in
// methods/registry.cpp. A spec names itself, gives its defaults over the
// stages' (the paper's), and lists the parameter rows it reads: a flag for a
// row that some other method or scheme reads but this one does not is an
// error naming where it applies (unused_param()). Sign convention: positive
// inside.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "isoloft/core/section.h"
#include "isoloft/core/slice_stack.h"
#include "isoloft/interp/z_stream.h"
#include "isoloft/objects/result.h"
#include "isoloft/objects/slice_fields.h"

namespace isoloft {

struct ReconstructParams;
class SharedPartition;

/// One input as a method reads it: a slice stack (working pixels), and the
/// sections a reader gave in world space when it gave them (a CSL file; the
/// stack is then empty), with the label of those sections to reconstruct.
struct MethodInput {
  const SliceStack& stack;
  const std::vector<Section>& sections;
  std::uint32_t section_label = 0;
  /// The labels of `sections` as one partition, shared with the jobs of the
  /// other labels (field3d/partition3d.h); null: `section_label` alone.
  SharedPartition* partition = nullptr;
  /// Label input: only these labels (ReconstructOptions::labels; empty = all).
  std::vector<std::uint32_t> labels{};
  /// ReconstructOptions::on_estimate: per object before its work is allocated.
  std::function<void(const WorkEstimate&)> on_estimate{};
};

/// A method: slices (or sections) to fields.
struct MethodSpec {
  std::string name;  ///< as in --method and the report
  std::string doc;   ///< one line: what it is, with the paper section or reference
  /// Its changes to the stages' defaults (e.g. the z spline, the z scheme).
  std::function<void(ReconstructParams&)> defaults;
  /// The method-specific parameter rows it reads: keys, or prefixes ending
  /// in '.'. Rows no method lists are read by every method.
  std::vector<std::string> rows;
  /// Whether it fits curves (its slices report MPU statistics, --dump-stages).
  bool fits_curves = false;
  /// The columns family: one slice's field over the object's crop box.
  std::function<SliceField(const SliceInput&, const ReconstructParams&)> slice_field;
  /// A family of its own: its whole run of one input (objects, warnings,
  /// times); unset for the columns family. It has no slice fields or sampled
  /// planes (ReconstructOptions' hooks, --volume, --labelmap, --dump-stages).
  std::function<ReconstructResult(const MethodInput&, const ReconstructParams&)> reconstruct;
  /// Reads sections at any angle (a CSL file's), not only parallel slices.
  bool reads_sections = false;
};

/// What a z scheme needs to build its plane source for one object.
struct ZSchemeInput {
  std::vector<double> z;      ///< every knot (end caps included), increasing
  int width = 0, height = 0;  ///< the crop box
  ZStream::NextKnot next;     ///< the knots' fields in z order, one per call
  ResidentCount* count = nullptr;  ///< counts the fields held
  std::size_t block = 0;  ///< columns: intervals per ZStream block (0: kZStreamBlock)
};

/// A z scheme: the slice fields to the planes Marching Cubes reads.
struct ZSchemeSpec {
  std::string name;  ///< as in --z-scheme and the report
  std::string doc;   ///< one line, with the paper section or reference
  /// The scheme-specific parameter rows it reads (as MethodSpec::rows).
  std::vector<std::string> rows;
  /// Knots it holds at once beyond the slices in flight, for the work
  /// estimate; nullopt: all of them.
  std::function<std::optional<std::size_t>(const ReconstructParams&)> resident_knots;
  std::function<std::unique_ptr<PlaneSource>(ZSchemeInput, const ReconstructParams&)> make;
};

/// The registered methods and z schemes, in registry order.
const std::vector<MethodSpec>& methods();
const std::vector<ZSchemeSpec>& z_schemes();

/// \throw ParamError naming the known names if `name` is not registered.
const MethodSpec& method_spec(const std::string& name);
/// The registered method of that name, or null.
const MethodSpec* find_method(const std::string& name);
const ZSchemeSpec& z_scheme_spec(const std::string& name);

/// The names, for a parameter row's choices.
std::vector<std::string> method_names();
/// The methods that read sections at any angle (MethodSpec::reads_sections), comma-separated.
std::string section_method_names();
std::vector<std::string> z_scheme_names();

/// If parameter row `key` is read by some method or z scheme but not by
/// `method` nor `scheme`: where it applies ("only with --method isoloft,
/// marker2006"); else "" (the row applies).
std::string unused_param(const std::string& key, const std::string& method, const std::string& scheme);

namespace detail {
/// True if `key` is `row` or lies under a `row` ending in '.'.
bool row_matches(const std::string& row, const std::string& key);
/// The rows the curve-fitting methods read and the baseline does not (marker2006.cpp).
const std::vector<std::string>& curve_fit_rows();
/// The paper reproduction's z defaults (marker2006, levin): the stages' own
/// InterpParams spline (Hyman's) and end caps (dome) over isoloft's (marker2006.cpp).
void paper_interp_defaults(ReconstructParams& p);
}  // namespace detail

}  // namespace isoloft
