#pragma once
// What every benchmark program in bench/ shares: its command line, a description of the machine it
// ran on, where results go, writing them (JSON, plus CSV for tables of rows), and aligned tables
// on stdout. See bench/README.md for the file format.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <type_traits>
#include <vector>

#include "dofcache/image/image.h"
#include "dofcache/render/renderer.h"
#include "dofcache/scene/accel.h"

namespace dofcache::bench {

// CPU model, logical cores, memory, OS, kernel, compiler, build type, UTC date/time, git commit
// (when DOFCACHE_SOURCE_DIR is a git checkout). Fields that cannot be determined are null.
nlohmann::json machine_description();

// <DOFCACHE_SOURCE_DIR>/bench/results, or $DOFCACHE_BENCH_RESULTS if set; created if needed.
// Throws dofcache::Error if it cannot be created.
std::string results_dir();

// "" if `name` can name a results file, otherwise what is wrong with it. <name>.json and <name>.csv
// must be plain files inside results_dir(), so a name is 1 to 100 of [A-Za-z0-9_.-] and does not
// start with '.' or '-'.
std::string results_name_problem(const std::string& name);

// Writes <results_dir>/<name>.json as {"machine": machine_description(), "results": results}.
// If results["rows"] is an array of flat objects (values are strings, numbers, booleans or null),
// also writes <name>.csv with one column per key. nlohmann::json sorts object keys, so the column
// order comes from results["columns"] (an array of key names, e.g. Table::header()) when present;
// keys it does not list follow in sorted order. Both files are written atomically. Returns the
// JSON file's path. Throws dofcache::Error on failure, or if results_name_problem(name) is not "".
std::string write_results(const std::string& name, const nlohmann::json& results);

// A converged reference image, rendered once per machine: <results_dir>/references/<key>.exr if it
// exists, otherwise `render()` (announced on stderr), stored there and returned. `key` must
// identify everything the image depends on (scene, size, samples, lens, frame).
image::Image cached_reference(const std::string& key, const std::function<image::Image()>& render);

// What a user gets for the camera at `width` pixels: the camera's aspect ratio, the scene's lens
// (or the default one, resolved as the CLI resolves it), default shading, no progress display.
// With `lens_file`, the real lens of `render --lens-file` (its table's stop, autofocus).
render::RenderSettings camera_settings(const scene::Scene& scene, const scene::Accel& accel,
                                       const scene::Camera& camera, int width, int spp,
                                       int threads, const std::string& lens_file = "");

// The converged reference of one scene view: uncached DRT of `base` (size, lens, shading) with
// `spp` samples and a seed independent of the measured renders, through cached_reference keyed by
// scene name, size, samples and scene identity.
image::Image converged_reference(const std::string& scene_name, const scene::Scene& scene,
                                 const scene::Accel& accel, const scene::Camera& camera,
                                 const render::RenderSettings& base, int spp);

// Rows as CSV text (RFC 4180 quoting; the format write_results uses), columns in `column_order`
// first. Throws dofcache::Error unless `rows` is an array of flat objects.
std::string rows_to_csv(const nlohmann::json& rows,
                        const std::vector<std::string>& column_order = {});

// --- Command line ----------------------------------------------------------------------------
// Each program declares its options on a CLI::App, the shared ones through these helpers (one
// name, range and help text everywhere), then calls parse_command_line or, for Google Benchmark
// programs, parse_benchmark_command_line. --help shows every option with its default: the value
// its variable holds before parsing.

// A numeric option's check: min <= value <= max, with an error that says whether the value was
// out of range or not a number at all (CLI::Range calls both "not in range").
CLI::Validator in_range(int min, int max);
CLI::Validator in_range(double min, double max);

// --width W (image width in pixels, 1..16384), --threads T (render threads, 0: all cores) and
// --results NAME (add_results_option).
void add_common_options(CLI::App& app, int& width, int& threads, std::string& results);

// --results NAME: write <results_dir>/NAME.{json,csv}; `results` holds the default name. Checked
// with results_name_problem while parsing, not after the measurements.
CLI::Option* add_results_option(CLI::App& app, std::string& results);

// An integer option (sample counts, repeats) in minimum..2^20, the range the dofcache CLI allows
// for --spp.
CLI::Option* add_count_option(CLI::App& app, const std::string& name, int& value,
                              const std::string& help, int minimum = 1);

// --rays N: camera rays generated per measurement of a ray-generation benchmark.
CLI::Option* add_rays_option(CLI::App& app, int& rays);

// Camera-ray generation as the renderer calls it (Sobol film and lens points, a weighted lens ray,
// a colour band per ray when `banded`): `count` rays over the film through `camera` on this
// thread. The directions' sum goes to *sink so the work is not dropped.
struct RayTiming {
  double seconds = 0;
  double passed = 0;  // the share of rays with weight > 0
};
RayTiming time_camera_rays(const render::ThinLensCamera& camera, int count, bool banded,
                           float* sink);
// The same rays generated in blocks of 16 (ThinLensCamera::lens_rays: a real lens traces them
// several at a time), as the renderer generates a pixel's.
RayTiming time_camera_rays_batched(const render::ThinLensCamera& camera, int count, bool banded,
                                   float* sink);

// --scene FILE, repeatable: a file in the source tree's scenes/ directory; `scenes` holds the
// default list, which the given files replace.
CLI::Option* add_scene_option(CLI::App& app, std::vector<std::string>& scenes);

// <DOFCACHE_SOURCE_DIR>/scenes/<file>.
std::string scene_path(const std::string& file);

// Parses argv into the options declared on `app` (named after the program). --help prints the
// help and exits with status 0; an unknown flag, a value that is not a number, out of range or
// otherwise invalid prints one line, "<program>: error: ... (see --help)", and exits with 2.
void parse_command_line(CLI::App& app, int argc, char** argv);

// The same for Google Benchmark programs: its flags (--benchmark_NAME=VALUE, --v=N) go to
// benchmark::Initialize (--help lists them too); any other unknown argument is an error as above.
void parse_benchmark_command_line(CLI::App& app, int argc, char** argv);

// Runs a program's work: an exception (a scene that fails to load, a results directory that cannot
// be written) ends the program with one line, "<program>: error: ...", and exit status 1, instead
// of std::terminate's abort. Returns body()'s status otherwise.
int run_guarded(const CLI::App& app, const std::function<int()>& body);

// A table printed with aligned columns: text left-aligned, numbers right-aligned.
//   Table t({"cache", "time [ms]", "relMSE"}, 3);
//   t.add_row({"octree", Table::Cell(12.345, 1), 0.00123});
//   t.print();
//   write_results("cache_lookup", {{"columns", t.header()}, {"rows", t.to_json()}});
class Table {
 public:
  // One entry: text, an integer, or a floating-point number with its own precision (digits
  // after the point; -1 uses the table's default).
  struct Cell {
    enum class Kind { Text, Integer, Real, Boolean };

    Cell(std::string s) : text(std::move(s)) {}
    Cell(const char* s) : text(s) {}
    template <class T, std::enable_if_t<std::is_integral_v<T> && !std::is_same_v<T, bool>, int> = 0>
    Cell(T v) : kind(Kind::Integer), text(std::to_string(v)) {}
    Cell(bool v) : kind(Kind::Boolean), text(v ? "true" : "false") {}
    Cell(double v, int precision = -1) : kind(Kind::Real), value(v), precision(precision) {}

    Kind kind = Kind::Text;
    std::string text;  // text, integers and booleans; reals are formatted when printed
    double value = 0;
    int precision = -1;
  };

  explicit Table(std::vector<std::string> header, int default_precision = 3);

  // Throws std::invalid_argument if the row's length differs from the header's.
  void add_row(std::vector<Cell> row);

  const std::vector<std::string>& header() const { return header_; }
  size_t rows() const { return rows_.size(); }
  std::string str() const;
  void print(std::FILE* out = stdout) const;

  // The rows as an array of objects keyed by the header, numbers as numbers (non-finite ones as
  // null): ready to store under "rows" for write_results, with header() under "columns".
  nlohmann::json to_json() const;

 private:
  std::string format(const Cell& cell) const;

  std::vector<std::string> header_;
  std::vector<std::vector<Cell>> rows_;
  int default_precision_;
};

// Writes `results` with the table's rows and columns added (write_results) and prints "wrote
// <path>" on stdout, as every table-printing benchmark ends. Returns the JSON file's path.
std::string write_table(const std::string& name, const Table& table,
                        nlohmann::json results = nlohmann::json::object());

}  // namespace dofcache::bench
