#include "cli_report.hpp"

#include "hdt/transfer.hpp"

#include "hdt/winding_tree.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

namespace hdt::cli {
namespace {

// ---- JSON: flat enough to write by hand --------------------------------------------

std::string quoted(const std::string& s) {
  std::string q = "\"";
  for (const unsigned char c : s) {
    if (c == '"' || c == '\\') {
      q += '\\';
      q += char(c);
    } else if (c < 0x20) {
      char esc[8];
      std::snprintf(esc, sizeof esc, "\\u%04x", c);
      q += esc;
    } else {
      q += char(c);
    }
  }
  return q + "\"";
}

// %.17g round-trips a double exactly; JSON has no NaN or infinity.
std::string number(double v, const char* format = "%.17g") {
  if (!std::isfinite(v)) return "null";
  char text[64];
  std::snprintf(text, sizeof text, format, v);
  return text;
}
std::string number(uint64_t v) { return std::to_string(v); }

// The members of one object, in insertion order.
class JsonObject {
public:
  JsonObject& add(const char* key, const std::string& json) {
    text_ += (text_.empty() ? "" : ",") + quoted(key) + ":" + json;
    return *this;
  }
  std::string str() const { return "{" + text_ + "}"; }

private:
  std::string text_;
};

std::string orNull(const std::string& path) { return path.empty() ? "null" : quoted(path); }

// ---- table ----------------------------------------------------------------------------

std::string withCommas(uint64_t v) {
  std::string digits = std::to_string(v), out;
  for (size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return out;
}

std::string fixed(double v, int decimals) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", decimals, v);
  return text;
}

std::string bytes(uint64_t b) {
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB"};
  double v = double(b);
  int u = 0;
  for (; v >= 1024 && u < 4; ++u) v /= 1024;
  return u == 0 ? std::to_string(b) + " B" : fixed(v, v < 10 ? 2 : v < 100 ? 1 : 0) + " " + units[u];
}

std::string ms(double v) { return fixed(v, v < 10 ? 2 : 1) + " ms"; }

struct Row {
  std::string label, value, note;
  bool aligned = true; // numbers line up on the right; names and paths do not
};

std::string phasesJson(const PhaseTimes& t) {
  JsonObject time;
  time.add("mapping", number(t.mapping, "%.3f"))
      .add("branching", number(t.branching, "%.3f"))
      .add("leaf", number(t.leaf, "%.3f"))
      .add("classify", number(t.classify, "%.3f"))
      .add("total", number(t.total, "%.3f"));
  return time.str();
}

size_t slowestRank(const std::vector<RankReport>& ranks) {
  size_t slowest = 0;
  for (size_t i = 1; i < ranks.size(); ++i)
    if (ranks[i].phases.total > ranks[slowest].phases.total) slowest = i;
  return slowest;
}

std::string ranksJson(const std::vector<RankReport>& ranks) {
  if (ranks.empty()) return "null";
  std::string out = "[";
  for (size_t i = 0; i < ranks.size(); ++i) {
    const RankReport& k = ranks[i];
    JsonObject row;
    row.add("rank", number(uint64_t(i)))
        .add("backend", quoted(k.backend))
        .add("device", std::to_string(k.device))
        .add("root_cells", number(k.rootCells))
        .add("leaf_grids", number(k.leafGrids))
        .add("time_ms", phasesJson(k.phases))
        .add("exchange_ms", number(k.exchangeMs, "%.3f"))
        .add("copy_back_ms", number(k.copyBackMs, "%.3f"))
        .add("send_ms", number(k.sendMs, "%.3f"))
        .add("peak_host_bytes", number(k.peakHostBytes))
        .add("peak_device_bytes", number(k.peakDeviceBytes));
    out += (i ? "," : "") + row.str();
  }
  return out + "]";
}

} // namespace

void writeJson(std::ostream& out, const Report& r) {
  std::string warnings = "[";
  for (const std::string& w : r.warnings) warnings += (warnings.size() > 1 ? "," : "") + quoted(w);

  const Volume& v = *r.volume;
  const Statistics& s = v.stats;
  const GridSpec& g = v.grid;
  const std::string origin =
      "[" + number(g.origin[0]) + "," + number(g.origin[1]) + "," + number(g.origin[2]) + "]";
  JsonObject io;
  io.add("read", number(r.io.read, "%.3f"))
      .add("prepare", number(r.io.prepare, "%.3f"))
      .add("write", number(r.io.write, "%.3f"))
      .add("transfer", number(r.io.transfer, "%.3f"))
      .add("device_wait", number(r.io.deviceWait, "%.3f"))
      .add("build", number(r.io.build, "%.3f"))
      .add("estimate_wait", number(r.io.estimateWait, "%.3f"))
      .add("since_start", number(r.io.sinceStart, "%.3f"))
      .add("reserve_wait", number(r.io.reserveWait, "%.3f"))
      .add("release_wait", number(r.io.releaseWait, "%.3f"))
      .add("unix_at_main", number(r.io.unixAtMain, "%.3f"))
      .add("unix_at_report", number(r.io.unixAtReport, "%.3f"));

  JsonObject o;
  o.add("mesh", quoted(r.mesh))
      .add("triangles", number(s.triangles))
      .add("resolution", number(uint64_t(g.resolution)))
      .add("root_grid", number(uint64_t(g.rootGrid)))
      .add("leaf_size", number(uint64_t(g.leafSize)))
      .add("height", number(uint64_t(g.height)))
      .add("origin", origin)
      .add("voxel_size", number(g.voxelSize))
      .add("tree_elements", number(s.treeElements))
      .add("leaf_grids", number(s.leafGrids))
      .add("leaf_voxels", number(s.leafVoxels))
      .add("active_voxels", number(s.activeVoxels))
      .add("inside_voxels", number(s.insideVoxels))
      .add("paper_bits_per_active_voxel", number(s.paperBitsPerActiveVoxel, "%.6g"))
      .add("topology_bytes", number(s.topologyBytes))
      .add("leaf_bytes", number(s.leafBytes))
      .add("backend", quoted(s.backend))
      .add("threads", std::to_string(s.threads))
      .add("time_ms", phasesJson(s.time))
      .add("peak_host_bytes", number(s.peakHostBytes))
      .add("degenerate_triangles", number(s.degenerateTriangles))
      .add("closed_mesh", v.closedMesh ? "true" : "false")
      .add("peak_device_bytes", number(s.peakDeviceBytes))
      .add("surface_only", v.surfaceOnly ? "true" : "false")
      .add("io_ms", io.str())
      .add("hdt_file", orNull(r.hdtPath))
      .add("dense_file", orNull(r.densePath))
      .add("duplicate_triangles", number(r.duplicateTriangles))
      .add("warnings", warnings + "]")
      .add("host_bytes_estimate", number(r.hostBytesEstimate))
      .add("inside_test", v.surfaceOnly ? "null" : quoted(insideTestName(v.insideTest)))
      .add("inside_test_requested", quoted(insideTestName(r.requestedInsideTest)))
      .add("inside_test_reason",
           v.surfaceOnly ? "null" : quoted(insideTestReason(r.requestedInsideTest, v.insideTest, v.closedMesh)))
      .add("winding_refined_elements", number(s.windingRefinedElements));
  std::string labels = r.labelled ? "[" : "null";
  for (const LabelStatistics& l : r.labels) {
    JsonObject row;
    row.add("label", number(uint64_t(l.label)))
        .add("name", quoted(l.name))
        .add("surface_voxels", number(l.surfaceVoxels))
        .add("inside_voxels", number(l.insideVoxels))
        .add("volume", number(l.volume, "%.9g"))
        .add("surface_area", number(l.surfaceArea, "%.9g"));
    labels += (labels.size() > 1 ? "," : "") + row.str();
  }
  if (r.labelled) labels += "]";
  o.add("labels", labels)
      .add("label_bytes", number(r.labelBytes))
      .add("dense_labels_file", orNull(r.denseLabelsPath));
  std::string arrays = "[";
  for (const VoxelArray& a : v.arrays) {
    JsonObject row;
    row.add("name", quoted(a.name))
        .add("source", quoted(a.source == ArraySource::Point ? "point" : "cell"))
        .add("components", number(uint64_t(a.components)));
    arrays += (arrays.size() > 1 ? "," : "") + row.str();
  }
  o.add("transferred_arrays", arrays + "]").add("transferred_array_bytes", number(voxelArrayBytes(v)));
  o.add("ranks", ranksJson(r.ranks)).add("slowest_rank", r.ranks.empty() ? "null" : number(uint64_t(slowestRank(r.ranks))));
  out << o.str() << '\n';
}

void writeTable(std::ostream& out, const Report& r) {
  const Volume& v = *r.volume;
  const Statistics& s = v.stats;
  const GridSpec& g = v.grid;
  const int L = g.leafSize;
  std::vector<Row> rows = {
      {"mesh", r.mesh, "", false},
      {"triangles", withCommas(s.triangles),
       withCommas(s.degenerateTriangles) + " degenerate dropped; " +
           (v.closedMesh ? "closed" : "open") +
           (r.duplicateTriangles ? "; " + withCommas(r.duplicateTriangles) + " duplicated" : "")},
      {"inside test", v.surfaceOnly ? "-" : insideTestName(v.insideTest),
       v.surfaceOnly ? "surface-only build" : insideTestReason(r.requestedInsideTest, v.insideTest, v.closedMesh)},
      {"resolution", std::to_string(g.resolution) + "^3", "voxels"},
      {"root grid", std::to_string(g.rootGrid) + "^3", "cells"},
      {"octree height", std::to_string(g.height), "levels"},
      {"leaf grid", std::to_string(L) + "^3", "voxels"},
      {"voxel size", number(g.voxelSize, "%.6g"), "mesh units"},
      {"origin",
       "(" + number(g.origin[0], "%.6g") + ", " + number(g.origin[1], "%.6g") + ", " +
           number(g.origin[2], "%.6g") + ")",
       "mesh units, low corner of voxel (0, 0, 0)", false},
      {"tree elements", withCommas(s.treeElements), "root cells + octree nodes"},
      {"leaf grids", withCommas(s.leafGrids), ""},
      {"leaf voxels", withCommas(s.leafVoxels), "voxels in leaf grids"},
      {"active voxels", withCommas(s.activeVoxels), "surface"},
      {"inside voxels", v.surfaceOnly ? "-" : withCommas(s.insideVoxels),
       v.surfaceOnly ? "surface-only build" : "full elements included"},
      {"bits / active voxel", number(s.paperBitsPerActiveVoxel, "%.3g"), "topology, 20-byte elements (paper)"},
      {"topology", bytes(s.topologyBytes), "4 bytes an element"},
      {"leaf data", bytes(s.leafBytes), std::to_string(L * L * L / 4) + " bytes a leaf grid"},
      {"backend", s.backend, s.backend == "cpu" ? std::to_string(s.threads) + " threads" : ""},
      {"read mesh", ms(r.io.read), ""},
      {"prepare", ms(r.io.prepare), "validate, place, snap"},
      {"mapping", ms(s.time.mapping), "T1: triangles to root cells"},
      {"branching", ms(s.time.branching), "T2: octree levels"},
      {"leaf", ms(s.time.leaf), "T3: surface voxels"},
      {"classify", ms(s.time.classify), "inside / outside"},
      {"build total", ms(s.time.total), ""},
      {"peak host memory", bytes(s.peakHostBytes), "resident set"},
  };
  if (s.backend == "cuda") rows.push_back({"peak device memory", bytes(s.peakDeviceBytes), ""});
  for (size_t i = 0; i < r.ranks.size(); ++i) {
    const RankReport& k = r.ranks[i];
    rows.push_back({"  rank " + std::to_string(i), ms(k.phases.total),
                    k.backend + (k.device >= 0 ? " " + std::to_string(k.device) : "") + ", " +
                        withCommas(k.leafGrids) + " leaf grids, exchange " + ms(k.exchangeMs) + ", copy back " +
                        ms(k.copyBackMs) + ", send " + ms(k.sendMs) + ", peak host " + bytes(k.peakHostBytes) +
                        (k.device >= 0 ? ", peak device " + bytes(k.peakDeviceBytes) : "")});
  }
  if (!r.hdtPath.empty()) rows.push_back({"wrote", r.hdtPath, "", false});
  if (!r.densePath.empty()) rows.push_back({"wrote", r.densePath, "dense uint8 NRRD", false});
  if (r.labelled) rows.push_back({"labels", bytes(r.labelBytes), std::to_string(r.labels.size()) + " labels"});
  for (const LabelStatistics& l : r.labels) {
    rows.push_back({"  label " + std::to_string(l.label), withCommas(l.surfaceVoxels + l.insideVoxels),
                    withCommas(l.surfaceVoxels) + " surface, volume " + number(l.volume, "%.4g") + ", area " +
                        number(l.surfaceArea, "%.4g") + (l.name.empty() ? "" : ", " + l.name)});
  }
  if (!r.denseLabelsPath.empty()) rows.push_back({"wrote", r.denseLabelsPath, "dense uint16 label NRRD", false});
  for (const VoxelArray& a : v.arrays)
    rows.push_back({"transferred " + a.name, bytes(a.values.size() * sizeof(float)),
                    std::string(a.source == ArraySource::Point ? "point" : "cell") + " data, " +
                        std::to_string(a.components) + " component(s), " + ms(r.io.transfer)});

  size_t labelWidth = 0, valueWidth = 0;
  for (const Row& row : rows) {
    labelWidth = std::max(labelWidth, row.label.size());
    if (row.aligned) valueWidth = std::max(valueWidth, row.value.size());
  }
  for (const Row& row : rows) {
    std::string line = row.label + std::string(labelWidth + 2 - row.label.size(), ' ');
    if (row.aligned) line += std::string(valueWidth - row.value.size(), ' ');
    line += row.value;
    if (!row.note.empty()) line += "  " + row.note;
    out << line << '\n';
  }
}

} // namespace hdt::cli
