// HTG conversion benchmark: how fast an hdt::Volume becomes a vtkHyperTreeGrid
// (vtkHDTToHyperTreeGrid::Convert), in HTG cells per second on one core, and
// how its time compares with the voxelization that made the volume.
//
//   hdt_htg_conversion_bench --meshes DIR [--out FILE.md] [--resolutions 1024,2048,4096]
//                            [--root 16] [--leaf 16] [--repeat 3] [--only NAME,...]
//                            [--tree-build reader|descriptor] [--note TEXT]
//
// Meshes are read with VTK's readers (STL, OBJ, PLY) and go through the same
// vtkPolyData -> hdt::TriangleMesh path as the filter. Voxelization = prepareMesh
// + the CPU driver on all cores. Conversion is timed with one thread (the
// target: >= 30 M cells/s) and with all threads; each is the best of --repeat.
#include "vtkHDTHyperTreeGridConversion.h"
#include "vtkHDTMeshConversion.h"

#include "hdt/builder.hpp"
#include "hdt/error.hpp"
#include "hdt/mesh.hpp"
#include "hdt/volume.hpp"

#include "vtkHyperTreeGrid.h"
#include "vtkNew.h"
#include "vtkOBJReader.h"
#include "vtkPLYReader.h"
#include "vtkPolyData.h"
#include "vtkSTLReader.h"
#include "vtkSmartPointer.h"
#include "vtkVersion.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <time.h>
#include <dirent.h>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace
{
using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0)
{
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// CPU time of the calling thread: a one-thread conversion runs entirely on it
// (task_arena(1) executes on the caller), so this is its cost even on a
// machine shared with other work.
double threadCpuMs()
{
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) * 1e3 + double(ts.tv_nsec) * 1e-6;
}

std::vector<std::string> split(const std::string& s)
{
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
  {
    if (!item.empty())
    {
      out.push_back(item);
    }
  }
  return out;
}

bool endsWith(const std::string& s, const std::string& suffix)
{
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

vtkSmartPointer<vtkPolyData> readMesh(const std::string& path)
{
  if (endsWith(path, ".stl"))
  {
    vtkNew<vtkSTLReader> r;
    r->SetFileName(path.c_str());
    r->Update();
    return r->GetOutput();
  }
  if (endsWith(path, ".ply"))
  {
    vtkNew<vtkPLYReader> r;
    r->SetFileName(path.c_str());
    r->Update();
    return r->GetOutput();
  }
  vtkNew<vtkOBJReader> r;
  r->SetFileName(path.c_str());
  r->Update();
  return r->GetOutput();
}

std::string firstLineWith(const char* file, const char* key)
{
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line))
  {
    if (line.rfind(key, 0) == 0)
    {
      const size_t colon = line.find(':');
      return colon == std::string::npos ? line : line.substr(colon + 2);
    }
  }
  return "?";
}

struct Row
{
  std::string mesh;
  int resolution = 0;
  uint64_t triangles = 0;
  uint64_t activeVoxels = 0;
  vtkIdType cells = 0, leaves = 0;
  int depth = 0;
  double voxelizeMs = 0;
  double convert1Ms = 0, convert1TreeMs = 0, convert1WalkMs = 0, convert1PackMs = 0;
  double convert1CpuMs = 0;
  double convertAllMs = 0;
  std::string note;
};
} // namespace

int main(int argc, char** argv)
{
  std::string meshDir, outPath, only, note;
  std::vector<int> resolutions = { 1024, 2048, 4096 };
  int root = 16, leaf = 16, repeat = 3;
  bool breadthFirst = false; // --tree-build descriptor: BuildFromBreadthFirstOrderDescriptor
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    auto next = [&]() -> std::string { return i + 1 < argc ? argv[++i] : ""; };
    if (a == "--meshes")
      meshDir = next();
    else if (a == "--out")
      outPath = next();
    else if (a == "--resolutions")
    {
      resolutions.clear();
      for (const auto& r : split(next()))
        resolutions.push_back(std::stoi(r));
    }
    else if (a == "--root")
      root = std::stoi(next());
    else if (a == "--leaf")
      leaf = std::stoi(next());
    else if (a == "--repeat")
      repeat = std::max(1, std::stoi(next()));
    else if (a == "--only")
      only = next();
    else if (a == "--note")
      note = next();
    else if (a == "--tree-build")
      breadthFirst = next() == "descriptor";
    else
    {
      std::cerr << "unknown argument " << a << "\n";
      return 2;
    }
  }
  if (meshDir.empty())
  {
    std::cerr << "usage: " << argv[0] << " --meshes DIR [--out FILE.md] [--resolutions 1024,2048]"
              << " [--root R] [--leaf L] [--repeat K] [--only a.stl,b.obj]"
              << " [--tree-build reader|descriptor] [--note TEXT]\n";
    return 2;
  }

  std::vector<std::string> files;
  if (DIR* d = opendir(meshDir.c_str()))
  {
    while (dirent* e = readdir(d))
    {
      const std::string name = e->d_name;
      if (endsWith(name, ".stl") || endsWith(name, ".obj") || endsWith(name, ".ply"))
        files.push_back(name);
    }
    closedir(d);
  }
  std::sort(files.begin(), files.end());
  if (!only.empty())
  {
    const std::vector<std::string> keep = split(only);
    files.erase(std::remove_if(files.begin(), files.end(),
                  [&](const std::string& f) {
                    return std::find(keep.begin(), keep.end(), f) == keep.end();
                  }),
      files.end());
  }
  if (files.empty())
  {
    std::cerr << "no meshes in " << meshDir << "\n";
    return 1;
  }

  std::vector<Row> rows;
  for (const std::string& file : files)
  {
    vtkSmartPointer<vtkPolyData> pd = readMesh(meshDir + "/" + file);
    hdt::TriangleMesh mesh;
    vtkHDTMeshConversionInfo meshInfo;
    vtkHDTMeshConversion::AppendPolyData(pd, mesh, meshInfo);
    pd = nullptr;
    for (int n : resolutions)
    {
      Row row;
      row.mesh = file;
      row.resolution = n;
      try
      {
        hdt::BuildConfig config;
        config.resolution = n;
        config.rootGrid = root;
        config.leafSize = leaf;
        hdt::BuildOptions options;
        options.backend = hdt::Backend::Cpu;
        auto t0 = Clock::now();
        hdt::Volume volume = hdt::build(hdt::prepareMesh(mesh, config), options);
        row.voxelizeMs = msSince(t0);
        row.triangles = volume.stats.triangles;
        row.activeVoxels = volume.stats.activeVoxels;

        vtkHDTConversionOptions conv;
        conv.AddFieldData = false;
        conv.TreeBuild = breadthFirst ? vtkHDTConversionOptions::BREADTH_FIRST_DESCRIPTOR
                                      : vtkHDTConversionOptions::INITIALIZE_FOR_READER;
        row.convert1Ms = row.convertAllMs = 1e300;
        for (int r = 0; r < repeat; ++r)
        {
          vtkNew<vtkHyperTreeGrid> htg;
          conv.Threads = 1;
          const double cpu0 = threadCpuMs();
          const vtkHDTConversionInfo info = vtkHDTToHyperTreeGrid::Convert(volume, conv, htg);
          const double cpu = threadCpuMs() - cpu0;
          row.convert1CpuMs = r == 0 ? cpu : std::min(row.convert1CpuMs, cpu);
          if (info.Milliseconds < row.convert1Ms)
          {
            row.convert1Ms = info.Milliseconds;
            row.convert1TreeMs = info.TreeBuildMilliseconds;
            row.convert1WalkMs = info.WalkMilliseconds;
            row.convert1PackMs = info.PackMilliseconds;
          }
          row.cells = info.Cells;
          row.leaves = info.LeafCells;
          row.depth = info.Depth;
        }
        for (int r = 0; r < repeat; ++r)
        {
          vtkNew<vtkHyperTreeGrid> htg;
          conv.Threads = 0;
          const vtkHDTConversionInfo info = vtkHDTToHyperTreeGrid::Convert(volume, conv, htg);
          row.convertAllMs = std::min(row.convertAllMs, info.Milliseconds);
        }
      }
      catch (const std::exception& e)
      {
        row.note = e.what();
      }
      std::fprintf(stderr,
        "%-26s %5d  cells %11lld  voxelize %9.1f ms  convert(1) %9.1f ms = %6.1f M/s  "
        "convert(all) %9.1f ms  [walk %.0f pack %.0f vtk %.0f] %s\n",
        row.mesh.c_str(), row.resolution, (long long)row.cells, row.voxelizeMs, row.convert1Ms,
        row.cells / (row.convert1Ms * 1e3), row.convertAllMs, row.convert1WalkMs, row.convert1PackMs,
        row.convert1TreeMs, row.note.c_str());
      rows.push_back(row);
    }
  }

  // Report.
  std::ostringstream md;
  char date[64];
  const std::time_t now = std::time(nullptr);
  std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
  const unsigned cores = std::thread::hardware_concurrency();
  md << "# HTG conversion benchmark\n\n"
     << "hdt::Volume -> vtkHyperTreeGrid (`vtkHDTToHyperTreeGrid::Convert`, full depth, "
        "MaskOutside on, no field data), produced by `bench/htg_conversion.cxx` "
        "(`hdt_htg_conversion_bench`).\n\n"
     << "- Date: " << date << "\n"
     << "- Machine: " << firstLineWith("/proc/cpuinfo", "model name") << ", " << cores
     << " hardware threads, " << firstLineWith("/proc/meminfo", "MemTotal") << "\n"
     << "- VTK " << vtkVersion::GetVTKVersion() << " (ParaView 5.11 bundle), compiler "
#if defined(__clang__)
     << "clang " << __clang_version__
#elif defined(__GNUC__)
     << "gcc " << __VERSION__
#endif
     << "\n"
     << "- Configuration: R = " << root << ", L = " << leaf << "; best of " << repeat
     << " conversions; VTK trees built with "
     << (breadthFirst ? "`BuildFromBreadthFirstOrderDescriptor`" : "`InitializeForReader`")
     << "\n"
     << "- Voxelization: `prepareMesh` + CPU driver on all " << cores
     << " threads (the filter's default when there is no GPU).\n"
     << "- Conversion (1 thread): everything, VTK's tree construction included; walk / pack / "
        "VTK are its parts (the per-tree walks, packing the codes into the output arrays, VTK's "
        "tree creation and build). \"CPU time\" is the converting thread's own CPU time, "
        "which other jobs on the machine do not inflate.\n"
     << (note.empty() ? std::string() : "- Note: " + note + "\n") << "\n"
     << "Targets: >= 30 M HTG cells/s on one core; conversion time <= voxelization time at 2K.\n\n"
     << "| Mesh | N | Triangles | Surface voxels | HTG cells | Depth | Voxelize ms | Convert ms (1 thr) "
        "| M cells/s (1 thr) | M cells/s (1 thr, CPU time) | walk / pack / VTK ms | Convert / voxelize | Convert ms (all thr) |\n"
     << "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  char buf[512];
  for (const Row& r : rows)
  {
    if (!r.note.empty())
    {
      md << "| " << r.mesh << " | " << r.resolution << " | failed: " << r.note
         << " | | | | | | | | | | |\n";
      continue;
    }
    std::snprintf(buf, sizeof buf,
      "| %s | %d | %llu | %llu | %lld | %d | %.0f | %.0f | %.1f | %.1f | %.0f / %.0f / %.0f | %.2f | %.0f |\n",
      r.mesh.c_str(), r.resolution, (unsigned long long)r.triangles,
      (unsigned long long)r.activeVoxels, (long long)r.cells, r.depth, r.voxelizeMs, r.convert1Ms,
      r.cells / (r.convert1Ms * 1e3), r.cells / (r.convert1CpuMs * 1e3), r.convert1WalkMs, r.convert1PackMs, r.convert1TreeMs,
      r.convert1Ms / r.voxelizeMs,
      r.convertAllMs);
    md << buf;
  }
  // Summary per resolution.
  md << "\n| N | Total HTG cells | M cells/s (1 thr, all meshes) | M cells/s (1 thr, CPU time) "
        "| Convert / voxelize (sum) |\n"
     << "|---:|---:|---:|---:|---:|\n";
  for (int n : resolutions)
  {
    double cells = 0, conv = 0, convCpu = 0, vox = 0;
    for (const Row& r : rows)
    {
      if (r.resolution == n && r.note.empty())
      {
        cells += double(r.cells);
        conv += r.convert1Ms;
        convCpu += r.convert1CpuMs;
        vox += r.voxelizeMs;
      }
    }
    if (conv > 0)
    {
      std::snprintf(buf, sizeof buf, "| %d | %.0f | %.1f | %.1f | %.2f |\n", n, cells,
        cells / (conv * 1e3), cells / (convCpu * 1e3), conv / vox);
      md << buf;
    }
  }
  std::cout << md.str();
  if (!outPath.empty())
  {
    std::ofstream(outPath) << md.str();
  }
  return 0;
}
