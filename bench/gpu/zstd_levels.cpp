// The .hdt leaf data's zstd blocks at several settings (issue 18: the write's
// compression is most of hdt-voxelize's write): size, compression and
// decompression time of the real leaf words of a .hdt file, every 2 MiB block
// compressed on all cores as the writer does (one-shot, one frame a block).
//
//   hdt_zstd_levels FILE.hdt [--repeat R] [--out RUNS.jsonl] [SETTING...]
//   hdt_zstd_levels --same A.hdt B.hdt   (exit 0 when both hold the same volume
//       once decoded, whatever their levels: every section but the run's
//       measurements, compared as raw-leaf files)
//
// SETTING: a level (3, 1, -1, ...), or LEVEL:nolit (literals stored raw),
// LEVEL:lit (literals Huffman-coded even at negative levels), then any of
// :mm=N :hl=N :cl=N :wl=N :st=N :tl=N (minMatch, hashLog, chainLog, windowLog,
// strategy, targetLength over the level's own). Default: a sweep.
// Each setting prints one JSON line: the best of R runs.
#include "hdt/hdt_file.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#define ZSTD_STATIC_LINKING_ONLY // ZSTD_c_literalCompressionMode, for the sweep only
#include <zstd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;
constexpr size_t kBlock = size_t(1) << 21;

struct Setting {
  std::string name;
  int level = 3;
  int literals = 0; // ZSTD_ps_auto, enable (1), disable (2)
  std::vector<std::pair<ZSTD_cParameter, int>> params; // over the level's own
};

Setting parseSetting(const std::string& s) {
  Setting t;
  t.name = s;
  std::stringstream in(s);
  std::string part;
  std::getline(in, part, ':');
  t.level = std::stoi(part);
  while (std::getline(in, part, ':')) {
    if (part == "lit" || part == "nolit") {
      t.literals = part == "lit" ? 1 : 2;
      continue;
    }
    const std::string key = part.substr(0, part.find('='));
    const int value = std::stoi(part.substr(part.find('=') + 1));
    const ZSTD_cParameter p = key == "mm"   ? ZSTD_c_minMatch
                              : key == "hl" ? ZSTD_c_hashLog
                              : key == "cl" ? ZSTD_c_chainLog
                              : key == "wl" ? ZSTD_c_windowLog
                              : key == "st" ? ZSTD_c_strategy
                                            : ZSTD_c_targetLength; // tl
    t.params.emplace_back(p, value);
  }
  return t;
}

// A's and B's volumes written with raw leaves and without the measurements
// that differ between any two runs: the same bytes or not.
int sameDecoded(const char* a, const char* b) {
  auto rawBytes = [](const char* path) {
    hdt::Volume v = hdt::readHdt(path);
    v.stats.time = {};
    v.stats.peakHostBytes = v.stats.peakDeviceBytes = 0;
    v.stats.threads = 0;
    hdt::HdtWriteOptions raw;
    raw.compressLeaves = false;
    return hdt::serializeHdt(v, raw);
  };
  const bool same = rawBytes(a) == rawBytes(b);
  std::cout << (same ? "same decoded volume: " : "DIFFERENT decoded volumes: ") << a << " " << b << std::endl;
  return same ? 0 : 1;
}

double msSince(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

} // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: hdt_zstd_levels FILE.hdt [--repeat R] [--out RUNS.jsonl] [SETTING...]\n";
    return 2;
  }
  if (std::string(argv[1]) == "--same" && argc == 4) return sameDecoded(argv[2], argv[3]);
  int repeat = 3;
  std::string out;
  std::vector<Setting> settings;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--repeat" && i + 1 < argc) repeat = std::stoi(argv[++i]);
    else if (a == "--out" && i + 1 < argc) out = argv[++i];
    else settings.push_back(parseSetting(a));
  }
  if (settings.empty())
    for (const char* s : {"3", "2", "1", "-1", "-2", "-3", "-5", "-1:lit", "-3:lit", "1:nolit"})
      settings.push_back(parseSetting(s));

  const hdt::Volume v = hdt::readHdt(argv[1]);
  const uint8_t* data = reinterpret_cast<const uint8_t*>(v.leafWords.data());
  const size_t bytes = v.leafWords.size() * sizeof(uint32_t);
  const size_t blocks = (bytes + kBlock - 1) / kBlock;
  const size_t bound = ZSTD_compressBound(kBlock);
  std::vector<std::vector<uint8_t>> frames(blocks);
  std::vector<uint8_t> back(bytes);

  for (const Setting& s : settings) {
    struct Ctx {
      std::unique_ptr<ZSTD_CCtx, size_t (*)(ZSTD_CCtx*)> c{ZSTD_createCCtx(), ZSTD_freeCCtx};
      std::unique_ptr<ZSTD_DCtx, size_t (*)(ZSTD_DCtx*)> d{ZSTD_createDCtx(), ZSTD_freeDCtx};
      std::vector<uint8_t> scratch;
    };
    tbb::enumerable_thread_specific<Ctx> ctx;
    double bestC = 1e300, bestD = 1e300;
    size_t stored = 0;
    bool same = true;
    for (int r = 0; r < repeat; ++r) {
      Clock::time_point t = Clock::now();
      tbb::parallel_for(size_t(0), blocks, [&](size_t i) {
        Ctx& c = ctx.local();
        if (c.scratch.size() < bound) c.scratch.resize(bound);
        ZSTD_CCtx_reset(c.c.get(), ZSTD_reset_session_and_parameters);
        ZSTD_CCtx_setParameter(c.c.get(), ZSTD_c_compressionLevel, s.level);
        ZSTD_CCtx_setParameter(c.c.get(), ZSTD_c_contentSizeFlag, 1);
        if (s.literals) ZSTD_CCtx_setParameter(c.c.get(), ZSTD_c_literalCompressionMode, s.literals);
        for (const auto& [p, value] : s.params) {
          const size_t e = ZSTD_CCtx_setParameter(c.c.get(), p, value);
          if (ZSTD_isError(e)) throw std::runtime_error(ZSTD_getErrorName(e));
        }
        const size_t n = std::min(kBlock, bytes - i * kBlock);
        const size_t got = ZSTD_compress2(c.c.get(), c.scratch.data(), bound, data + i * kBlock, n);
        if (ZSTD_isError(got)) throw std::runtime_error(ZSTD_getErrorName(got));
        frames[i].assign(c.scratch.data(), c.scratch.data() + got);
      });
      bestC = std::min(bestC, msSince(t));
      t = Clock::now();
      std::atomic<bool> ok{true};
      tbb::parallel_for(size_t(0), blocks, [&](size_t i) {
        Ctx& c = ctx.local();
        const size_t n = std::min(kBlock, bytes - i * kBlock);
        const size_t got = ZSTD_decompressDCtx(c.d.get(), back.data() + i * kBlock, n, frames[i].data(), frames[i].size());
        if (ZSTD_isError(got) || got != n) ok = false;
      });
      bestD = std::min(bestD, msSince(t));
      same = same && ok && std::equal(back.begin(), back.end(), data);
    }
    stored = 0;
    for (const auto& f : frames) stored += f.size();
    std::ostringstream j;
    j << "{\"file\": \"" << argv[1] << "\", \"setting\": \"" << s.name << "\", \"level\": " << s.level
      << ", \"raw_bytes\": " << bytes << ", \"stored_bytes\": " << stored << ", \"ratio\": " << double(bytes) / stored
      << ", \"compress_ms\": " << bestC << ", \"decompress_ms\": " << bestD << ", \"repeat\": " << repeat
      << ", \"threads\": " << tbb::this_task_arena::max_concurrency() << ", \"round_trip\": " << (same ? "true" : "false")
      << "}";
    std::cout << j.str() << std::endl;
    if (!out.empty()) std::ofstream(out, std::ios::app) << j.str() << "\n";
  }
  return 0;
}
