// Question: how long does each stage take on a stack the size of the paper's
// jawbone (48 slices of 500x500, paper Table 3: MPU, Dist, Fltr, Intrp, Mesh)?
// A synthesized shape is cut into exactly N slices across its height; each
// method runs R times and the median of every stage is reported.
//
// usage: stage_times [--shape branching-cylinders] [--size 500] [--slices 48] [--runs 3] [--threads N] [--out FILE.json]
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <iostream>

#include "experiment_util.h"
#include "isoloft/pipeline.h"
#include "isoloft/synth/synth.h"

using namespace isoloft;
using isoloft::experiments::median;

int main(int argc, char** argv) {
  std::string shape = "branching-cylinders", out;
  int size = 500, slices = 48, runs = 3, threads = 0;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--shape") shape = v;
    else if (a == "--size") size = std::stoi(v);
    else if (a == "--slices") slices = std::stoi(v);
    else if (a == "--runs") runs = std::stoi(v);
    else if (a == "--threads") threads = std::stoi(v);
    else if (a == "--out") out = v;
    else {
      std::cerr << "unknown option " << a << "\n";
      return 2;
    }
  }
  std::unique_ptr<tbb::global_control> gc;
  if (threads > 0) gc = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
  const auto s = make_default_shape(shape, size);
  const auto [lo, hi] = s->bounds();
  SynthParams sp;
  sp.size = size;
  sp.first_offset = 0.37;
  sp.z_spacing = (hi.z() - lo.z()) / (slices - 1 + 2 * sp.first_offset);
  const SynthResult syn = synthesize(*s, sp);
  nlohmann::json report = {{"shape", shape},
                           {"size", size},
                           {"slices", syn.stack.slices.size()},
                           {"z_spacing_px", sp.z_spacing},
                           {"runs", runs},
                           {"threads", int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism))}};
  for (Method m : {Method::Isoloft, Method::Marker2006, Method::Levin}) {
    std::map<std::string, std::vector<double>> t;
    long triangles = 0;
    for (int r = 0; r < runs; ++r) {
      const ReconstructParams p = method_defaults(m);
      const auto t0 = std::chrono::steady_clock::now();
      const ReconstructResult res = reconstruct(syn.stack, p);
      t["wall"].push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      const auto& st = res.times;
      t["contour"].push_back(st.contour);
      t["mpu"].push_back(st.mpu);
      t["dist"].push_back(st.dist);
      t["filter"].push_back(st.filter);
      t["interp"].push_back(st.interp);
      t["mesh"].push_back(st.mesh);
      t["total"].push_back(st.total());
      triangles = long(res.objects.front().mesh.triangles.size());
    }
    nlohmann::json med;
    for (const auto& [k, v] : t) med[k] = median(v);
    report[to_string(m)] = {{"median_s", med}, {"all_s", t}, {"triangles", triangles}};
    std::cerr << to_string(m) << ": " << med.dump() << "\n";
  }
  if (!out.empty()) std::ofstream(out) << report.dump(2) << "\n";
  else std::cout << report.dump(2) << "\n";
  return 0;
}
