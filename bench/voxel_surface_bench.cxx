// Voxel surface benchmark: the HDT's own surface extraction (port 1 of the
// HDT Voxelizer: hdt::extractVoxelSurface + the copy into vtkPolyData) against
// ParaView's way to the same picture, vtkHyperTreeGridGeometry on the hyper
// tree grid of the same volume (port 0, Mask Outside on as by default).
//
//   hdt_voxel_surface_bench MESH [MESH...] [--resolutions 1024,2048] [--root 16]
//                           [--leaf 16] [--repeat 3] [--no-htg]
//
// Prints one markdown table row per mesh and resolution. All cores; times are
// wall clock, the surface the best of --repeat, the HTG geometry run once
// (it takes minutes).
#include "vtkHDTHyperTreeGridConversion.h"
#include "vtkHDTMeshConversion.h"
#include "vtkHDTVoxelSurface.h"

#include "hdt/builder.hpp"
#include "hdt/mesh.hpp"
#include "hdt/volume.hpp"
#include "hdt/voxel_surface.hpp"

#include "vtkHyperTreeGrid.h"
#include "vtkHyperTreeGridGeometry.h"
#include "vtkNew.h"
#include "vtkOBJReader.h"
#include "vtkPLYReader.h"
#include "vtkPolyData.h"
#include "vtkSTLReader.h"
#include "vtkSmartPointer.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

namespace
{
using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0)
{
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

bool endsWith(const std::string& s, const std::string& suffix)
{
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

template <class Reader>
vtkSmartPointer<vtkPolyData> read(const std::string& path)
{
  vtkNew<Reader> r;
  r->SetFileName(path.c_str());
  r->Update();
  return r->GetOutput();
}

vtkSmartPointer<vtkPolyData> readMesh(const std::string& path)
{
  if (endsWith(path, ".stl"))
    return read<vtkSTLReader>(path);
  if (endsWith(path, ".ply"))
    return read<vtkPLYReader>(path);
  return read<vtkOBJReader>(path);
}

std::string baseName(const std::string& path)
{
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}
} // namespace

int main(int argc, char** argv)
{
  std::vector<std::string> meshes;
  std::vector<int> resolutions = { 1024, 2048 };
  int root = 16, leaf = 16, repeat = 3;
  bool htg = true;
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    auto next = [&]() -> std::string { return i + 1 < argc ? argv[++i] : ""; };
    if (a == "--resolutions")
    {
      resolutions.clear();
      std::stringstream ss(next());
      std::string item;
      while (std::getline(ss, item, ','))
        resolutions.push_back(std::stoi(item));
    }
    else if (a == "--root")
      root = std::stoi(next());
    else if (a == "--leaf")
      leaf = std::stoi(next());
    else if (a == "--repeat")
      repeat = std::max(1, std::stoi(next()));
    else if (a == "--no-htg")
      htg = false;
    else
      meshes.push_back(a);
  }
  if (meshes.empty())
  {
    std::cerr << "usage: " << argv[0] << " MESH... [--resolutions 1024,2048] [--no-htg]\n";
    return 2;
  }

  std::cout << "| mesh | N | voxelize ms | surface ms (core) | surface ms (vtkPolyData) | quads merged | "
               "faces unmerged | HTG geometry ms | HTG geometry polygons | speed-up |\n"
               "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const std::string& path : meshes)
  {
    vtkSmartPointer<vtkPolyData> poly = readMesh(path);
    hdt::TriangleMesh mesh;
    vtkHDTMeshConversionInfo meshInfo;
    vtkHDTMeshConversion::AppendDataObject(poly, mesh, meshInfo);
    for (int n : resolutions)
    {
      hdt::BuildConfig config;
      config.resolution = n;
      config.rootGrid = root;
      config.leafSize = leaf;
      hdt::BuildOptions options;
      options.backend = hdt::Backend::Cpu;
      auto t0 = Clock::now();
      const hdt::Volume volume = hdt::voxelize(mesh, config, options);
      const double voxelizeMs = msSince(t0);

      double coreMs = 1e300, vtkMs = 1e300;
      long long quads = 0;
      for (int k = 0; k < repeat; ++k)
      {
        t0 = Clock::now();
        quads = (long long)hdt::extractVoxelSurface(volume).quadCount();
        coreMs = std::min(coreMs, msSince(t0));
        vtkNew<vtkPolyData> surface;
        t0 = Clock::now();
        vtkHDTFillVoxelSurface(volume, -1, surface);
        vtkMs = std::min(vtkMs, msSince(t0));
      }
      hdt::SurfaceOptions unmerged;
      unmerged.merge = false;
      const size_t faces = hdt::extractSurfaceQuads(volume, unmerged).size();

      double geometryMs = 0;
      vtkIdType polygons = 0;
      if (htg)
      {
        vtkNew<vtkHyperTreeGrid> grid;
        vtkHDTConversionOptions conversion;
        conversion.MaskOutside = true;
        vtkHDTToHyperTreeGrid::Convert(volume, conversion, grid);
        vtkNew<vtkHyperTreeGridGeometry> geometry;
        geometry->SetInputData(grid);
        t0 = Clock::now();
        geometry->Update();
        geometryMs = msSince(t0);
        polygons = vtkPolyData::SafeDownCast(geometry->GetOutputDataObject(0))->GetNumberOfCells();
      }
      char row[512];
      std::snprintf(row, sizeof row, "| %s | %d | %.0f | %.1f | %.1f | %lld | %zu | %.0f | %lld | %s |\n",
        baseName(path).c_str(), n, voxelizeMs, coreMs, vtkMs, quads, faces, geometryMs,
        (long long)polygons,
        htg ? (std::to_string(int(geometryMs / vtkMs + 0.5)) + "x").c_str() : "-");
      std::cout << row << std::flush;
    }
  }
  return 0;
}
