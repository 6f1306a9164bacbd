// Question (paper Fig. 8): what do the library's z splines look like through
// a handful of data values, with and without the monotonicity constraint?
// Evaluates every SplineKind through the given (z, v) data, once through
// Spline1D and once through ZInterpolator on 1x1 grids (the path the
// pipeline uses per pixel); the two must agree (float precision), else exit 1.
//
// usage: spline_curves --z 0,1,2,3,4 --v 0,0.1,0.9,1,1 [--samples 400] --out FILE.csv [--points FILE.csv]
//   FILE.csv:   z,monotone,catmull_rom,natural,linear  (samples evenly over [z0, zn], ends included)
//   --points:   z,v  (the data points)
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <string>
#include <vector>

#include "experiment_util.h"
#include "isoloft/interp/spline.h"

using namespace isoloft;

namespace {
std::vector<double> parse_list(const std::string& s) {
  std::vector<double> v;
  for (const auto& item : experiments::split(s)) v.push_back(std::stod(item));
  return v;
}
}  // namespace

int main(int argc, char** argv) {
  std::vector<double> z, v;
  int samples = 400;
  std::string out, points;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) {
      std::cerr << "missing value after " << a << "\n";
      return 2;
    }
    const std::string val = argv[++i];
    if (a == "--z") z = parse_list(val);
    else if (a == "--v") v = parse_list(val);
    else if (a == "--samples") samples = std::stoi(val);
    else if (a == "--out") out = val;
    else if (a == "--points") points = val;
    else {
      std::cerr << "unknown option " << a << "\n";
      return 2;
    }
  }
  if (out.empty() || z.size() < 2 || z.size() != v.size() || samples < 2) {
    std::cerr << "usage: spline_curves --z z0,z1,... --v v0,v1,... [--samples N>=2] --out FILE.csv [--points FILE.csv]\n";
    return 2;
  }
  try {
    const SplineKind kinds[] = {SplineKind::Monotone, SplineKind::CatmullRom, SplineKind::Natural, SplineKind::Linear};
    std::vector<Spline1D> splines;
    std::vector<ZInterpolator> interps;
    for (auto k : kinds) {
      splines.emplace_back(z, v, k);
      std::vector<Grid2f> slices;
      for (double x : v) slices.emplace_back(1, 1, float(x));
      interps.emplace_back(std::move(slices), z, k);
    }
    std::ofstream f(out);
    f << "z,monotone,catmull_rom,natural,linear\n" << std::setprecision(10);
    double worst = 0;
    Grid2f g(1, 1);
    for (int s = 0; s < samples; ++s) {
      const double q = z.front() + (z.back() - z.front()) * s / (samples - 1);
      f << q;
      for (std::size_t k = 0; k < splines.size(); ++k) {
        const double a = splines[k](q);
        interps[k].evaluate(q, g);
        worst = std::max(worst, std::abs(a - double(g.data[0])) / std::max(1.0, std::abs(a)));
        f << ',' << a;
      }
      f << '\n';
    }
    if (!f) throw std::runtime_error("cannot write " + out);
    if (!points.empty()) {
      std::ofstream p(points);
      p << "z,v\n" << std::setprecision(10);
      for (std::size_t i = 0; i < z.size(); ++i) p << z[i] << ',' << v[i] << '\n';
      if (!p) throw std::runtime_error("cannot write " + points);
    }
    if (worst > 1e-5) {
      std::cerr << "Spline1D and ZInterpolator disagree by " << worst << "\n";
      return 1;
    }
  } catch (const std::exception& e) {
    std::cerr << "spline_curves: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
