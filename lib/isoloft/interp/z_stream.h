// @file interp/z_stream.h
// @brief The per-pixel z splines read plane by plane in increasing z (paper 2.4).
// PlaneSource is what the streaming mesher reads. ZStream gives the values of
// a ZInterpolator through all knots while holding only a window of them: the
// knots arrive in z order from a callback, and each block of intervals is a
// ZInterpolator over its knots plus the tangent reach on either side, so every
// tangent it uses is the whole column's, bit for bit (tested).
// @warning Natural splines couple every knot: ZStream then holds all of them.
#pragma once

#include <cstddef>
#include <deque>
#include <functional>
#include <optional>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/interp/spline.h"

namespace isoloft {

/// A z-interpolated field visited in increasing z: reach(k) before reading
/// knot interval k; then evaluate() in interval k and sides() of k and k - 1.
class PlaneSource {
 public:
  virtual ~PlaneSource() = default;
  [[nodiscard]] virtual int width() const = 0;
  [[nodiscard]] virtual int height() const = 0;
  [[nodiscard]] virtual std::size_t interval(double z) const = 0;  ///< as ZInterpolator::interval
  /// Makes interval k readable. \pre k not below an earlier reach.
  virtual void reach(std::size_t k) = 0;
  virtual void evaluate(double z, Grid2f& out) const = 0;  ///< as ZInterpolator::evaluate
  /// At least the pixels `only` (out already width x height); by default all.
  virtual void evaluate_runs(double z, Grid2f& out, const PixelRuns& only) const {
    (void)only;
    evaluate(z, out);
  }
  virtual void sides(std::size_t k, float iso, float margin, Grid2<std::int8_t>& out) const = 0;  ///< as ZInterpolator::sides
  /// Wall seconds spent preparing intervals in reach() (tangents,
  /// correspondences), knot pulls excluded.
  [[nodiscard]] virtual double setup_seconds() const { return 0; }
};

/// A whole ZInterpolator as a PlaneSource.
class WholeField final : public PlaneSource {
 public:
  explicit WholeField(const ZInterpolator& f) : f_(f) {}
  [[nodiscard]] int width() const override { return f_.width(); }
  [[nodiscard]] int height() const override { return f_.height(); }
  [[nodiscard]] std::size_t interval(double z) const override { return f_.interval(z); }
  void reach(std::size_t) override {}
  void evaluate(double z, Grid2f& out) const override { f_.evaluate(z, out); }
  void evaluate_runs(double z, Grid2f& out, const PixelRuns& only) const override { f_.evaluate(z, out, &only); }
  void sides(std::size_t k, float iso, float margin, Grid2<std::int8_t>& out) const override {
    f_.sides(k, iso, margin, out);
  }

 private:
  const ZInterpolator& f_;
};

/// How many 2D fields are held at once, now and at most (e.g. slices of a
/// reconstruction, over several holders).
struct ResidentCount {
  long now = 0, peak = 0;
  void add(long n) { now += n, peak = now > peak ? now : peak; }
  void remove(long n) { now -= n; }
  void change(long delta) { delta > 0 ? add(delta) : remove(-delta); }
};

/// Knots on each side that a knot's tangent depends on (the one-sided end
/// tangents included); nullopt: all of the column (Natural).
std::optional<std::size_t> tangent_reach(SplineKind kind);

/// Intervals per ZStream block: each block holds its knots with 2 reach + 1
/// more and the tangents of block + 2 knots (those shared with the block
/// before taken over, not recomputed).
inline constexpr std::size_t kZStreamBlock = 8;

class ZStream final : public PlaneSource {
 public:
  /// The knots' fields in z order, one per call, each width x height.
  using NextKnot = std::function<Grid2f()>;
  /// `z`: every knot (end caps included). `count`, if given, counts the
  /// fields held (knots and their tangents).
  /// \throw ParamError unless z has >= 2 increasing knots, sizes >= 1, block >= 1.
  ZStream(std::vector<double> z, SplineKind kind, int width, int height, NextKnot next, ResidentCount* count = nullptr,
          std::size_t block = kZStreamBlock);
  ~ZStream() override;
  ZStream(const ZStream&) = delete;
  ZStream& operator=(const ZStream&) = delete;

  [[nodiscard]] int width() const override { return width_; }
  [[nodiscard]] int height() const override { return height_; }
  [[nodiscard]] std::size_t interval(double z) const override;
  /// Pulls knots as needed. \throw ParamError for a knot of another size.
  void reach(std::size_t k) override;
  void evaluate(double z, Grid2f& out) const override;
  void evaluate_runs(double z, Grid2f& out, const PixelRuns& only) const override;
  void sides(std::size_t k, float iso, float margin, Grid2<std::int8_t>& out) const override;
  [[nodiscard]] double setup_seconds() const override { return tangent_seconds_; }  ///< computing tangents

 private:
  void next_block();
  const ZInterpolator& reached(double z) const;  // the window holding z's interval \throw ParamError if none
  void count(long delta) const;

  std::vector<double> z_;
  SplineKind kind_;
  int width_, height_;
  NextKnot next_;
  ResidentCount* count_;
  std::size_t block_, below_, above_;  // intervals per block; knots held below / above it
  std::deque<Grid2f> pulled_;          // knots [pulled_first_, pulled_first_ + size) not yet given to a block
  std::size_t pulled_first_ = 0;
  std::optional<ZInterpolator> window_;  // knots [w0_, w1_]; its exact intervals [e0_, e1_)
  std::size_t w0_ = 0, w1_ = 0, e0_ = 0, e1_ = 0;
  long held_ = 0;  // fields the window holds: its knots and tangents
  double tangent_seconds_ = 0;
};

}  // namespace isoloft
