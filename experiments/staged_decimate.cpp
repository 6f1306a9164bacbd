// Question: at the same certified bound, how many triangles and how much time
// does a staged decimation (DecimateParams::stages, stage_ratio) take against
// today's single pass (issue 37)? Decimates saved Marching Cubes meshes (PLY,
// pixel units, e.g. `reconstruct --decimate-error 0`) with each configuration
// in turn, the configurations alternating within each run (a shared machine:
// read paired ratios). Prints one CSV row per (mesh, e, configuration, run):
// triangles, wall s and process CPU s.
//
// usage: staged_decimate --mesh a.ply[,b.ply] [--errors 0.25,0.5,1] [--configs 1:0.5,2:0.25,3:0.25] [--runs 3]
//        [--threads 2]
#include <tbb/global_control.h>

#include <chrono>
#include <ctime>
#include <iostream>
#include <memory>

#include "experiment_util.h"
#include "isoloft/io/mesh_io.h"
#include "isoloft/mesh/decimate.h"

using namespace isoloft;

int main(int argc, char** argv) {
  std::vector<std::string> meshes, errors{"0.25", "0.5", "1"}, configs{"1:0.5", "2:0.25"};
  int runs = 3, threads = 2;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--mesh") meshes = experiments::split(v);
    else if (a == "--errors") errors = experiments::split(v);
    else if (a == "--configs") configs = experiments::split(v);
    else if (a == "--runs") runs = std::stoi(v);
    else if (a == "--threads") threads = std::stoi(v);
    else {
      std::cerr << "unknown option " << a << "\n";
      return 2;
    }
  }
  tbb::global_control gc(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
  std::cout << "mesh,e,stages,ratio,run,triangles_in,triangles_out,wall_s,cpu_s\n";
  for (const std::string& path : meshes) {
    const TriMesh original = read_mesh(path);
    for (const std::string& e : errors)
      for (int r = 0; r < runs; ++r)
        for (const std::string& c : configs) {
          DecimateParams p;
          p.max_error = std::stod(e);
          const auto colon = c.find(':');
          p.stages = std::stoi(c.substr(0, colon));
          p.stage_ratio = std::stod(c.substr(colon + 1));
          TriMesh mesh = original;
          const std::clock_t c0 = std::clock();
          const auto t0 = std::chrono::steady_clock::now();
          const DecimateResult d = decimate(mesh, p);
          const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          const double cpu = double(std::clock() - c0) / CLOCKS_PER_SEC;
          std::cout << path << "," << e << "," << p.stages << "," << p.stage_ratio << "," << r << ","
                    << d.triangles_before << "," << d.triangles_after << "," << wall << "," << cpu << std::endl;
        }
  }
}
