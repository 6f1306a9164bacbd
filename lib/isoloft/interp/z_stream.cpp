#include "isoloft/interp/z_stream.h"

#include <algorithm>
#include <chrono>
#include <string>

#include "isoloft/core/error.h"

namespace isoloft {

std::optional<std::size_t> tangent_reach(SplineKind kind) {
  switch (kind) {
    case SplineKind::Monotone: return 2;  // three-point tangents, one-sided over two knots at the column ends
    case SplineKind::ExtremumPreserving: return 2;  // its left and right parabolas: knots i-2 to i+2
    case SplineKind::CatmullRom: return 1;
    case SplineKind::Linear: return 0;
    case SplineKind::Natural: return std::nullopt;  // one tridiagonal system per column
  }
  return std::nullopt;  // a kind not listed: the whole column, exact at any reach
}

ZStream::ZStream(std::vector<double> z, SplineKind kind, int width, int height, NextKnot next, ResidentCount* count,
                 std::size_t block)
    : z_(std::move(z)), kind_(kind), width_(width), height_(height), next_(std::move(next)), count_(count) {
  if (z_.size() < 2) throw ParamError("z stream needs at least 2 knots");
  for (std::size_t i = 1; i < z_.size(); ++i)
    if (!(z_[i] > z_[i - 1])) throw ParamError("z stream knots must be strictly increasing (z[" + std::to_string(i) + "])");
  if (width < 1 || height < 1 || block < 1) throw ParamError("z stream: empty fields or blocks");
  const std::optional<std::size_t> r = tangent_reach(kind);
  block_ = r ? block : z_.size() - 1;
  above_ = r.value_or(z_.size());
  // Below, one knot more: sides() of the interval before the block (the
  // mesher's previous layer) needs that interval's lower tangent too (the
  // overshoot bound of every kind but monotone and linear).
  below_ = r ? above_ + 1 : above_;
}

ZStream::~ZStream() {
  count(-long(pulled_.size()));
  count(-held_);
}

void ZStream::count(long delta) const {
  if (count_) count_->change(delta);
}

std::size_t ZStream::interval(double q) const { return knot_interval(z_, q); }

void ZStream::next_block() {
  const std::size_t n = z_.size();
  e0_ = window_ ? e1_ : 0;
  e1_ = std::min(n - 1, e0_ + block_);
  // Tangents where they are used: evaluate() on this block's intervals
  // [e0, e1), sides() on those and the one before (the mesher's previous
  // layer). The last window's top knots, t0_knot..e0, are carried over: its
  // tangents there were the whole column's too.
  const std::size_t t0_knot = e0_ - std::min<std::size_t>(e0_, 1);
  std::vector<Grid2f> carried;
  // Fields held: the window's knots, and its tangents unless linear.
  auto tangent_fields = [&](std::size_t count) { return kind_ == SplineKind::Linear ? 0L : long(count); };
  if (window_) {
    carried = window_->take_tangents(t0_knot - w0_, e0_ - w0_);
    count(-held_ + tangent_fields(carried.size()));
  }
  window_.reset();
  w0_ = e0_ - std::min(e0_, below_);
  w1_ = std::min(n - 1, e1_ + above_);
  // Knots below this block's window are done with; pull up to its top.
  for (; pulled_first_ < w0_ && !pulled_.empty(); ++pulled_first_, count(-1)) pulled_.pop_front();
  while (pulled_first_ + pulled_.size() <= w1_) {
    Grid2f f = next_();
    if (f.width != width_ || f.height != height_)
      throw ParamError("z stream: knot " + std::to_string(pulled_first_ + pulled_.size()) + " is " +
                       std::to_string(f.width) + "x" + std::to_string(f.height) + ", expected " +
                       std::to_string(width_) + "x" + std::to_string(height_));
    pulled_.push_back(std::move(f));
    count(1);
  }
  // The knots the next window shares are copied, the rest moved.
  const std::size_t keep_from = e1_ < n - 1 ? e1_ - std::min(e1_, below_) : n;
  std::vector<Grid2f> knots;
  knots.reserve(w1_ - w0_ + 1);
  for (std::size_t i = w0_; i <= w1_; ++i) {
    Grid2f& f = pulled_[i - pulled_first_];
    if (i >= keep_from) knots.push_back(f);
    else knots.push_back(std::move(f));
  }
  for (; pulled_first_ < keep_from && !pulled_.empty(); ++pulled_first_, count(-1)) pulled_.pop_front();
  const auto t0 = std::chrono::steady_clock::now();
  const long kept = tangent_fields(carried.size());  // counted already
  window_.emplace(std::move(knots), std::vector<double>(z_.begin() + long(w0_), z_.begin() + long(w1_) + 1), kind_,
                  t0_knot - w0_, e1_ - w0_, std::move(carried));
  held_ = long(w1_ - w0_ + 1) + tangent_fields(e1_ - t0_knot + 1);
  count(held_ - kept);
  tangent_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void ZStream::reach(std::size_t k) {
  if (k > z_.size() - 2) throw ParamError("z stream: interval " + std::to_string(k) + " beyond the last knot");
  if (window_ && k < e0_) throw ParamError("z stream: interval " + std::to_string(k) + " was passed already");
  while (!window_ || k >= e1_) next_block();
}

const ZInterpolator& ZStream::reached(double z) const {
  const std::size_t k = interval(z);
  if (!window_ || k < e0_ || k >= e1_) throw ParamError("z stream: evaluate() outside the reached interval");
  return *window_;
}

void ZStream::evaluate(double z, Grid2f& out) const { reached(z).evaluate(z, out); }

void ZStream::evaluate_runs(double z, Grid2f& out, const PixelRuns& only) const { reached(z).evaluate(z, out, &only); }

void ZStream::sides(std::size_t k, float iso, float margin, Grid2<std::int8_t>& out) const {
  // The block's intervals and the one before: the window's tangents are those.
  if (!window_ || k + 1 < e0_ || k >= e1_) throw ParamError("z stream: sides() of an interval not held");
  window_->sides(k - w0_, iso, margin, out);
}

}  // namespace isoloft
