// @file field3d/field3d.h
// @brief One smooth 3D implicit field constrained by every drawn section, in
// any orientation (issue 35 item 2), and its surface.
// Formulation (docs/decisions.md: the field3d method): the unknown f lives on a
// regular grid over the contours' bounding box plus a margin; it minimises
//   smoothness * sum_interior (Lap_h f)^2 h^3
//   + sum_samples w_s (f(p_s) - d_s)^2 + boundary_weight * sum_faces (f + b)^2 h^2
// with f(p) trilinear and b = min(band, boundary_slope x the faces' least
// distance in cells to the contours' box; the band for a partition's labels). The samples cover every section plane inside the box:
// d_s is the in-plane signed distance to the plane's contours of the label
// (positive inside, even-odd nesting) clamped to +-band, so the whole plane's
// inside and outside is constrained while crossing planes, whose in-plane
// distances differ away from the contours, fight at most by the band; samples
// on the contours themselves (d = 0) weigh contour_weight per length. The
// normal equations are SPD; they are solved by conjugate gradients
// preconditioned by a geometric multigrid V-cycle, warm-started coarse to fine
// (the grid halved `levels - 1` times), matrix-free; a direct SimplicialLDLT on the assembled matrix is the twin
// (Field3dParams::direct, small grids only). The zero set is meshed by Marching
// Cubes (mesh/marching_cubes.h) on the grid padded with outside samples, so the
// mesh is closed and oriented.
// Crossing sections: where two planes meet, each one's contours cut their
// common line into inside intervals; where those disagree by more than
// conflict_tolerance a Conflict (its length) is reported. Rule: least squares
// averages the two planes' samples there (equal weights), so the surface
// passes between the two drawn crossings.
// Parallel stacks (opt-in, stack_spacing > 1): where every section is normal
// to one grid axis, the grid's spacing along that axis is the planes' spacing
// (or a divisor of it, at most stack_spacing cells; every plane on a node) and the bi-Laplacian takes
// per-axis spacings (the same continuous energy); the multigrid halves only
// the axes near the smallest spacing. The field is then splined (natural
// cubic, C2) back to one cell per pixel along that axis before Marching Cubes.
// Optional stages: a narrow band around the zero set re-solved on a grid
// `refinement` times finer (sparse: r^3 nodes per band cell, the coarse field
// fixed on a ring around it; conjugate gradients preconditioned by a V-cycle
// over the band at r, r/2, ..., 1; Marching Cubes on the fine grid, streamed
// by planes); `base_resolution` chooses it for a resolution above it (the
// dense solve at resolution / r: memory grows with the surface); re-weighting
// passes that make samples the field misses heavier and re-solve warm; and
// pruning of closed components that enclose no sample drawn inside.
// Units: world millimetres in and out; band, tolerances and spacings in grid cells.
// @warning A surface that would leave the padded box is cut by the boundary
// term (f pulled to -b on the box faces), so margin bounds how far the
// surface may bulge beyond the outermost contours; at a margin near 0, b is
// near 0 too (boundary_slope 0 keeps the band).
// Pixel input (sections that keep a label image beside their traced
// contours, field3d/image_sections.h): every pixel centre of the image is a
// sign constraint, inside (label `label`) f >= sign_margin, outside f <=
// -sign_margin; after the solve, the violated centres become penalty samples
// (target +-2 sign_margin, sign_weight; raised by reweight_factor while still
// violated) and the field is re-solved warm, at most sign_passes times: an
// active set, so the surface keeps every drawn pixel while the contour
// samples may lie on a smoothed boundary. With sign_guard (the pixel
// default) a centre still on its drawn side pulls only to sign_margin, and a
// penalty whose centre lies beyond its target is released (one-sided).
// Polyline input (plane_signs): the plane samples at least
// plane_sign_distance from the drawn contours are sign constraints too, by
// the same active set (their in-plane side).
// @warning A label-image section's contours are the boundary samples; an
// image without them constrains the signs at its pixel centres only.
#pragma once

#include <cstddef>
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "isoloft/core/mesh.h"
#include "isoloft/core/params.h"
#include "isoloft/core/section.h"
#include "isoloft/mesh/mesh_check.h"

namespace isoloft {

/// The most cells the grid rows (resolution, pixel_resolution) ask for along
/// a side, and the widest band (64x the tuned 16): an unbounded band made
/// a run that never ends.
inline constexpr double kMaxGridCells = 1024;

struct Field3dParams {
  int resolution = 96;
  double margin = 0.1;
  double band = 8.0;
  double smoothness = 1.0;
  double contour_weight = 100.0;
  double plane_weight = 0.03;
  double boundary_weight = 1.0;
  double boundary_slope = 1.5;
  double sample_spacing = 1.0;
  int levels = 3;
  double tolerance = 1e-5;
  int max_iterations = 4000;
  double conflict_tolerance = 0.5;
  bool direct = false;
  int refinement = 1;
  double refine_width = 2.0;
  int base_resolution = 0;
  int model_resolution = 0;
  int reweight_passes = 0;
  double reweight_factor = 4.0;
  double reweight_tolerance = 5e-4;
  bool prune = true;
  double stack_spacing = 1.0;
  bool plane_slope = false;
  double band_per_gap = 0.0;
  double plane_weight_per_gap = 0.0;
  bool pixel_signs = true;
  double pixel_sigma = 1.0;
  double pixel_band = 16.0;
  double pixel_contour_weight = 1.0;
  double sign_margin = 0.05;
  double sign_weight = 10.0;
  int sign_passes = 8;
  bool sign_guard = false;
  int pixel_resolution = 0;
  bool pixel_slope = true;
  double pixel_band_per_gap = 1.25;
  double pixel_plane_weight_per_gap = 0.00625;
  bool pixel_sign_guard = true;
  bool plane_signs = true;
  double plane_sign_distance = 1.0;
  double band_margin = 0.0;
  double pixel_band_margin = 0.0;
  /// The box (world mm, low and high corners) the grid covers before its
  /// margin, instead of the label's contours' box: labels solved on one box
  /// get one grid (field3d/partition3d.h). Not a parameter row (no flag).
  std::optional<std::array<Vec3d, 2>> box{};
};

/// `p` with the sparse field's choice made (Field3dParams::base_resolution):
/// resolution divided by the refinement r that brings it to base_resolution
/// or below (r = 2 or 4; rounded up), refinement set to r. Unchanged when
/// base_resolution is 0, resolution is at most it, or refinement is above 1.
Field3dParams sparse_base(const Field3dParams& p);

/// `p` with its cell-unit rows (band, smoothness against the data, contour weight, sign margin and distances,
/// conflict tolerance) converted from a grid of model_resolution cells to one of p.resolution, so the grid
/// resolves the same continuous energy. Unchanged when model_resolution is 0 or a section is a label image.
Field3dParams model_scaled(const Field3dParams& p, const std::vector<Section>& sections);

/// band_margin x the band in mm on cells of `cell` mm (band cells, or band_per_gap x `gap` mm if more).
double band_margin_mm(const Field3dParams& p, double cell, double gap);

/// The grid box's margins (mm) below and above the contours' box `box` (low and high corners) along each axis,
/// on cells of `cell` mm: margin x the box's diagonal and, with band_margin, at least band_margin_mm() (`gap`:
/// detail::median_gap(sections)), except beyond a parallel stack's closed end (an outermost plane beyond the
/// contours, e.g. an empty slice: its data close the field there). The band margin keeps the faces' pull to
/// -band no more negative than a distance field there: 4-5 cells beyond a small structure's open end, it bent
/// f up between the planes.
std::array<Vec3d, 2> box_margins(const Field3dParams& p, const std::vector<Section>& sections,
                                 const std::array<Vec3d, 2>& box, double cell, double gap);

/// Largest grid (nodes) the direct twin accepts: its LDLT fill grows as n^(5/3).
inline constexpr std::size_t kMaxDirectNodes = 40000;

template <>
inline const ParamTable<Field3dParams>& params_table<Field3dParams>() {
  static const ParamTable<Field3dParams> t({
      field("resolution", &Field3dParams::resolution, "cells",
            "grid cells along the box's longest side (96: armadillo's 26 planes within 5 s on 2 threads); polyline "
            "input only, pixel input follows pixel_resolution",
            between(4, kMaxGridCells)),
      field("margin", &Field3dParams::margin, "",
            "box margin around the contours, share of their bounding-box diagonal (room for caps beyond the "
            "outermost contours)",
            at_least(0)),
      field("band", &Field3dParams::band, "cells",
            "in-plane distances clamped to +-band: crossing planes disagree by at most this; 8 beat 3 on the OReX "
            "tuning sets (eight_15 Chamfer 0.20 -> 0.11 %, balloondog 2 -> 1 component); at most 1024 "
            "(kMaxGridCells; 1e308 ran without end, 1e6 took 14x 16's time on a 64 px sphere)",
            Range{0, kMaxGridCells, true, false}),
      field("smoothness", &Field3dParams::smoothness, "",
            "weight of the bi-Laplacian energy against the plane samples (tuned on eight_15, eight_20, balloondog)",
            above(0)),
      field("contour_weight", &Field3dParams::contour_weight, "per cell",
            "weight per cell of contour length of the f = 0 samples on drawn contours; 100 beat 10 on the OReX tuning "
            "sets (balloondog largest per-plane distance 34 -> 0.62 % of the diagonal: thin parts kept)",
            at_least(0)),
      field("plane_weight", &Field3dParams::plane_weight, "per cell^2",
            "weight per cell^2 of the clamped in-plane distance samples (inside/outside over the whole plane); 0.03 beat 1 "
            "on the OReX tuning sets (Chamfer eight_15 0.100 -> 0.067 %, balloondog 0.228 -> 0.189 %)",
            above(0)),
      field("boundary_weight", &Field3dParams::boundary_weight, "per cell^2",
            "weight per cell^2 pulling f to -b on the box faces (outside there; makes the system definite)",
            above(0)),
      field("boundary_slope", &Field3dParams::boundary_slope, "",
            "b = min(band, boundary_slope x the faces' least distance in cells to the contours' box; 0: band): "
            "a small structure's faces 4-5 cells out no longer pulled to -16, which bowed f up between its slices "
            "(1.5: the leaderboard's 4 tuning structures, median mean distance over the default's 1.205 -> 1.087, "
            "the 128 px mask kit unchanged; 1 and 1.3 cost its 16:1 rows; labels solved as one partition keep "
            "band; docs/decisions.md: field3d pixel input: the box a band beyond the contours)",
            between(0, 64)),
      field("sample_spacing", &Field3dParams::sample_spacing, "cells",
            "spacing of the samples on planes and along contours (1: about one per crossed cell)", above(0)),
      field("levels", &Field3dParams::levels, "levels",
            "grids of the coarse-to-fine warm start, spacing doubled per level (3: N/4, N/2, N)", between(1, 6)),
      field("tolerance", &Field3dParams::tolerance, "",
            "conjugate gradients stop at this relative residual |r| / |b| on every level", above(0)),
      field("max_iterations", &Field3dParams::max_iterations, "iterations",
            "conjugate-gradient iterations per level at most (a safety net)", at_least(1)),
      field("conflict_tolerance", &Field3dParams::conflict_tolerance, "cells",
            "crossing planes whose inside intervals on their common line disagree by more than this are reported",
            at_least(0)),
      field("direct", &Field3dParams::direct, "",
            "solve by SimplicialLDLT on the assembled system (the twin; small grids only)"),
      field("refinement", &Field3dParams::refinement, "",
            "the narrow band near the surface re-solved on a grid this many times finer (1: none; 2 or 4); 2 moved "
            "Chamfer by < 2 % on the OReX tuning sets, so off (base_resolution sets it for a resolution above a cap)",
            between(1, 4)),
      field("base_resolution", &Field3dParams::base_resolution, "cells",
            "sparse field: when resolution is above this (and refinement 1), the dense solve runs at resolution / r "
            "(r = 2 or 4, the smallest that brings it to this or below; 4 when none does) and the narrow band around "
            "its surface is re-solved r times finer, reaching resolution: memory grows with the surface, not the box "
            "(0: the dense grid at resolution)",
            between(0, kMaxGridCells)),
      field("refine_width", &Field3dParams::refine_width, "cells",
            "the band: grid cells holding the coarse surface or a drawn contour, dilated by this many cells",
            between(1, 8)),
      field("reweight_passes", &Field3dParams::reweight_passes, "passes",
            "re-solves with heavier samples where the field misses the drawn contour or its side", between(0, 8)),
      field("reweight_factor", &Field3dParams::reweight_factor, "",
            "a missed sample's weight is multiplied by this per pass", above(1)),
      field("reweight_tolerance", &Field3dParams::reweight_tolerance, "",
            "a contour sample is missed when |f| exceeds this share of the contours' bounding-box diagonal "
            "(half of issue 35's 0.1 % on the input planes)",
            above(0)),
      field("prune", &Field3dParams::prune, "",
            "drop closed components that enclose no sample drawn inside (spurious blobs between planes)"),
      field("plane_slope", &Field3dParams::plane_slope, "",
            "the in-plane distance samples scaled by 1/sqrt(1 + s^2), s its change per mm along the normal between "
            "the nearest parallel sections on either side: an estimate of the 3D distance, which the bi-Laplacian "
            "interpolates between planes without the in-plane distance's inward bias"),
      field("band_per_gap", &Field3dParams::band_per_gap, "",
            "band at least this times the median gap between neighbouring parallel sections (0: band alone; at "
            "most 8 gaps, 6x the pixel default: an unbounded band made a run that never ends)",
            between(0, 8)),
      field("plane_weight_per_gap", &Field3dParams::plane_weight_per_gap, "per cell^2 per cell",
            "plane weight at least this times the median gap (cells) between neighbouring parallel sections: the "
            "planes' data per unit volume falls as 1 / gap against the bi-Laplacian's, and this keeps it (0: "
            "plane_weight alone; at most 1)",
            between(0, 1)),
      field("pixel_signs", &Field3dParams::pixel_signs, "",
            "pixel input: every pixel centre of a label image kept on its drawn side (inside f >= sign_margin, "
            "outside f <= -sign_margin) by an active set of penalty samples"),
      field("pixel_sigma", &Field3dParams::pixel_sigma, "px",
            "pixel input: the boundary samples on the 1/2 level of the mask smoothed by a Gaussian of this sigma "
            "(0: on the traced boundary, mask_curve, which keeps every pixel but is faceted)",
            between(0, 8)),
      field("pixel_band", &Field3dParams::pixel_band, "cells",
            "pixel input: the band instead of field3d.band (a cell is at most a pixel); 16 beat 8 and 32 on the mask "
            "kit (torus 16:1 mean distance 1.25 px at 32, 0.15 at 16); at most 1024 as band",
            Range{0, kMaxGridCells, true, false}),
      field("pixel_contour_weight", &Field3dParams::pixel_contour_weight, "per cell",
            "pixel input: the contour weight instead of field3d.contour_weight (the boundary is smoothed; the sign "
            "constraints keep the pixels)",
            at_least(0)),
      field("sign_margin", &Field3dParams::sign_margin, "cells",
            "pixel input: a pixel centre is violated when f is on its drawn side by less than this; its penalty "
            "sample pulls f to twice this (sign_guard: to this while the centre is still on its drawn side)",
            above(0)),
      field("sign_weight", &Field3dParams::sign_weight, "",
            "pixel input: weight of a violated pixel centre's penalty sample (raised by reweight_factor per pass "
            "while it stays violated)",
            above(0)),
      field("sign_passes", &Field3dParams::sign_passes, "passes",
            "pixel input: re-solves of the active set at most (each adds the violated pixel centres)", between(0, 32)),
      field("sign_guard", &Field3dParams::sign_guard, "",
            "a violated sign point still on its drawn side pulls only to sign_margin (a guard for the mesh), one on "
            "the wrong side to twice it; a penalty whose point lies beyond its target is released (one-sided, as "
            "the inequality): the field is not pushed past where it already agrees (off: every violated point pulls "
            "to twice the margin and stays)"),
      field("pixel_sign_guard", &Field3dParams::pixel_sign_guard, "",
            "pixel input: sign_guard instead of field3d.sign_guard (the 128 px mask kit 18 of 18 rows at least as "
            "good as marker2006 against 17 off: sphere 4:1 normal angle 1.11 -> 1.01 deg against 1.04; the 64 px "
            "held-out check 10 of 17 either way)"),
      field("pixel_slope", &Field3dParams::pixel_slope, "",
            "pixel input: plane_slope instead of field3d.plane_slope (with pixel_band_per_gap, the mask kit: 16 of 18 rows at least as good as "
            "marker2006 in distance and angle against 7 without; ellipsoid 8:1 0.161 -> 0.076 px)"),
      field("band_margin", &Field3dParams::band_margin, "",
            "the box margin at least band_margin x the band (cells, or band_per_gap x the gap) in the planes' "
            "directions and beyond a stack's open end (box_margins()), so the faces' pull to -band is no more "
            "negative than a distance field there; 0: margin only",
            between(0, 4)),
      field("pixel_band_margin", &Field3dParams::pixel_band_margin, "",
            "pixel input: band_margin instead of field3d.band_margin (opt-in; 1.5 on the leaderboard, measured "
            "with boundary_slope 0: median mean distance over the default's 1.051 -> 1.015, but the 128 px mask kit's 16:1 rows worse, "
            "ellipsoid 0.187 -> 0.349 px; docs/decisions.md: field3d pixel input: the box a band beyond the contours)",
            between(0, 4)),
      field("pixel_band_per_gap", &Field3dParams::pixel_band_per_gap, "",
            "pixel input: band_per_gap instead of field3d.band_per_gap (1.25: band 20 at 16 px slices, where 16 "
            "left the ellipsoid 0.35 px inside midway and 24 broke the torus; at most 8 as band_per_gap)",
            between(0, 8)),
      field("pixel_plane_weight_per_gap", &Field3dParams::pixel_plane_weight_per_gap, "per cell^2 per cell",
            "pixel input: plane_weight_per_gap instead of field3d.plane_weight_per_gap (0.00625: weight 0.1 at 16 px "
            "gaps, 0.05 at 8, 4 px unchanged; the 128 px mask kit 17 of 18 rows at least as good as marker2006 "
            "against 16 at 0, the 64 px held-out check 10 of 17 either way)",
            between(0, 1)),
      field("pixel_resolution", &Field3dParams::pixel_resolution, "cells",
            "pixel input: grid cells along the box's longest side instead of field3d.resolution; 0: one cell per "
            "pixel (a finer grid gained nothing on the mask kit and cost up to 50x the time)",
            between(0, kMaxGridCells)),
      field("stack_spacing", &Field3dParams::stack_spacing, "cells",
            "on a parallel stack (every section normal to one grid axis), the solve's spacing along that axis: the "
            "planes' spacing split into steps of at most this many cells, each plane on a node; the field is then "
            "splined back to one cell along that axis for the mesh (1, the default: one cell along every axis). 8: "
            "frog's liver (planes 6 cells apart) 23.9 -> 14.2 s CPU, 1,011 -> 445 MiB, but input-slice Dice below "
            "0.999 on 2 of 16 leaderboard cases and eight_15's Hausdorff 0.51 -> 0.91 %, so opt-in",
            at_least(1)),
      field("plane_signs", &Field3dParams::plane_signs, "",
            "polyline input: every plane sample at least plane_sign_distance inside (outside) the drawn contours kept "
            "on its drawn side by the pixel input's active set (sign_margin, sign_weight, sign_passes), so the surface "
            "does not cross a plane where nothing was drawn; OReX tuning sets and the synthetic kit unchanged (no "
            "sample violated), held-out section max Elephant 3.9 -> 1.0 %, armadillo 1.8 -> 0.9 % and genus 1 -> 0, "
            "at 2.2x armadillo's time"),
      field("plane_sign_distance", &Field3dParams::plane_sign_distance, "cells",
            "polyline input: plane samples nearer the drawn contours than this are not sign constrained (the contour "
            "samples place the surface there)",
            Range{0, kMaxGridCells, false, false}),
      field("model_resolution", &Field3dParams::model_resolution, "cells",
            "polyline input: the grid resolution the cell-unit rows are given for (0: the grid's own); at another "
            "resolution they are converted so the grid discretises the same energy (a finer grid then resolves "
            "the same model instead of weighting the data more)",
            between(0, kMaxGridCells)),
  });
  return t;
}

/// Where two sections' contours disagree on their common line.
struct Field3dConflict {
  std::size_t a = 0, b = 0;  ///< indices of the two sections
  double size = 0;           ///< length of the interval inside for one and outside for the other, mm
  Vec3d where = Vec3d::Zero();  ///< its midpoint, world mm
};

/// How far the mesh's section on one input plane lies from the drawn contours.
struct Field3dPlaneResidual {
  std::size_t section = 0;
  double mesh_to_drawn = 0;  ///< largest distance of the mesh's section from the drawn contours, mm
  double drawn_to_mesh = 0;  ///< largest distance of the drawn contours from the mesh's section, mm
  [[nodiscard]] double max() const { return mesh_to_drawn > drawn_to_mesh ? mesh_to_drawn : drawn_to_mesh; }
};

struct Field3dResult {
  TriMesh mesh;  ///< world mm, closed, counter-clockwise seen from outside
  MeshCheck check;
  Vec3d origin = Vec3d::Zero();  ///< world position of grid node (0, 0, 0), mm
  double spacing = 0;            ///< finest grid spacing, mm
  int nx = 0, ny = 0, nz = 0;    ///< the field's grid: nodes per axis, spacing `spacing`
  std::vector<double> field;     ///< f at the field's nodes, x fastest (cells; positive inside)
  std::array<int, 3> solve_nodes{};    ///< the finest solve's nodes per axis (fewer along a parallel stack's normal)
  Vec3d solve_spacing = Vec3d::Zero(); ///< the finest solve's spacing per axis, mm
  std::size_t samples = 0;       ///< data samples (plane and contour)
  int iterations = 0;            ///< conjugate-gradient iterations over all levels (0 for direct)
  int finest_iterations = 0;     ///< of which on the finest grid
  int multigrid_levels = 0;      ///< grids of the finest solve's multigrid preconditioner (0 for direct)
  double residual = 0;           ///< final relative residual |A f - b| / |b| on the finest grid
  std::vector<Field3dPlaneResidual> planes;  ///< one per section
  std::vector<Field3dConflict> conflicts;    ///< larger than conflict_tolerance
  std::vector<std::string> warnings;         ///< one per conflict, naming both sections and the size
  double seconds = 0;                        ///< wall time of the whole call
  std::size_t band_unknowns = 0;             ///< unknowns of the refined band (0 without refinement)
  std::size_t band_nodes = 0;                ///< stored nodes of the band (unknowns and their fixed rings)
  int band_iterations = 0;                   ///< conjugate-gradient iterations on the band, all passes
  std::size_t reweighted = 0;                ///< samples made heavier, all passes
  std::size_t pruned_components = 0;         ///< closed components dropped (no inside sample enclosed)
  std::size_t sign_points = 0;               ///< sign points: label-image pixel centres in the box, polyline plane samples (plane_signs)
  std::size_t sign_active = 0;               ///< of which made penalty samples, all passes
  std::size_t sign_violated = 0;             ///< of which still on the wrong side of the margin at the end
  int sign_passes = 0;                       ///< active-set re-solves run
  int sign_iterations = 0;                   ///< of `iterations`, those of the active-set re-solves
  double sign_seconds = 0;                   ///< wall time of the active set (checks and re-solves, field and mesh)
};

/// One field's solve, for a run's report (`objects[i].field3d`): the grid,
/// the solver's work and residual, the sign constraints, the conflicts and
/// how far the mesh lies from the drawn contours on the input planes.
struct Field3dStats {
  std::array<int, 3> grid{};         ///< Field3dResult::nx, ny, nz
  std::array<int, 3> solve_nodes{};  ///< Field3dResult::solve_nodes
  std::size_t samples = 0;
  int iterations = 0, finest_iterations = 0, multigrid_levels = 0;
  double relative_residual = 0;      ///< Field3dResult::residual
  std::size_t sign_points = 0, sign_active = 0, sign_violated = 0;
  int sign_passes = 0;
  std::size_t conflicts = 0;
  double largest_conflict = 0;       ///< mm (0: none)
  std::size_t planes = 0;            ///< sections with a residual
  double mesh_to_drawn = 0;          ///< largest over the planes (Field3dPlaneResidual), mm
  double drawn_to_mesh = 0;          ///< largest over the planes, mm
  double seconds = 0;                ///< the field's wall time
};

/// The report's figures of `r`; `planes` replaces r.planes where the mesh
/// is not r's own (a partition's label meshed against its neighbours).
Field3dStats solve_stats(const Field3dResult& r, const std::vector<Field3dPlaneResidual>* planes = nullptr);

/// The surface of `label` from every section: one field over all planes.
/// \throw ParamError for params out of range, or direct with a grid above kMaxDirectNodes;
///        InputError naming the section (Section::source) for a non-orthonormal pose,
///        a label image whose pixel size is not positive and finite, a contour of < 3 points or a non-finite coordinate, and
///        when no section holds a contour of `label`.
Field3dResult reconstruct_sections(const std::vector<Section>& sections, std::uint32_t label,
                                   const Field3dParams& params = {});

/// What reconstruct_sections() will build for `label`, from the sections
/// alone, before any sample or grid is made: the input to a memory budget
/// (ReconstructOptions::on_estimate). An estimate, not a bound: its measured
/// ratio to peak RSS is in docs/decisions.md (field3d work estimate).
struct Field3dWork {
  int nx = 0, ny = 0, nz = 0;  ///< the field's grid nodes per axis (Field3dResult::nx, ny, nz)
  double solve_nodes = 0;      ///< the finest solve's nodes (Field3dResult::solve_nodes)
  double samples = 0;          ///< plane and contour samples
  double sign_points = 0;      ///< label-image pixel centres inside the box and polyline plane samples (plane_signs; Field3dResult::sign_points)
  double triangles = 0;        ///< Marching Cubes triangles (the contours' box as an ellipsoid)
  double band_nodes = 0;       ///< stored nodes of the refined band (Field3dResult::band_nodes; 0 without)
  double solve_bytes = 0;      ///< held at the finest solve: grid vectors, samples, operators, multigrid
  double field_bytes = 0;      ///< the finished field (Field3dResult::field)
  double mesh_bytes = 0;       ///< the mesh, its checks and per-plane residuals
  [[nodiscard]] double nodes() const { return double(nx) * double(ny) * double(nz); }
};

/// The work of reconstruct_sections(sections, label, params), counted (grid
/// and samples exactly; bytes per node, sample and triangle from the
/// solver's data structures). Time and memory O(sections' rows and vertices).
/// \throw as reconstruct_sections() for bad params and sections.
Field3dWork estimate_sections(const std::vector<Section>& sections, std::uint32_t label, const Field3dParams& params = {});

namespace detail {
/// Largest distances between the section of `mesh` by `pose`'s plane and the
/// closed polylines `drawn` (in-plane mm): {mesh -> drawn, drawn -> mesh}; +inf
/// for a side when the other is empty, 0 when both are.
Field3dPlaneResidual plane_section_distance(const TriMesh& mesh, const PlanePose& pose,
                                            const std::vector<std::vector<Vec2d>>& drawn);

/// Removes the closed components of `mesh` with positive volume (outward
/// shells) that enclose none of `inside` (points drawn inside; ray parity);
/// cavities' shells are kept. Returns how many were removed.
std::size_t prune_unsupported(TriMesh& mesh, const std::vector<Vec3d>& inside);

/// The multigrid's coarse operator (on an nx x ny x nz grid of unit cells)
/// built from samples at `g` (cell units) with weights `before` (0: absent),
/// then updated additively to weights `after`, against one built from
/// `after`: the largest entry of their difference (matrix and diagonal) over
/// the largest of the rebuilt matrix.
double coarse_update_mismatch(int nx, int ny, int nz, const std::vector<Vec3d>& g, const std::vector<double>& before,
                              const std::vector<double>& after, const Field3dParams& p = {});
/// The median over the sections of the distance to the nearest parallel section (mm; 0 without one).
double median_gap(const std::vector<Section>& sections);
}  // namespace detail

}  // namespace isoloft
