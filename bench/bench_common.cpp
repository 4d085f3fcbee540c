#include "bench_common.h"

#include "dofcache/cache/radiance_cache.h"
#include "dofcache/core/stopwatch.h"
#include "dofcache/render/sampler.h"
#include "dofcache/request/resolve.h"

#include <benchmark/benchmark.h>
#include <fmt/format.h>
#include <sys/utsname.h>
#include <tbb/info.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "dofcache/core/atomic_file.h"
#include "dofcache/core/error.h"
#include "dofcache/image/image_io.h"
#include "dofcache/render/setup.h"

#ifndef DOFCACHE_SOURCE_DIR
#define DOFCACHE_SOURCE_DIR "."
#endif

namespace dofcache::bench {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string trim(std::string s) {
  const char* space = " \t\r\n";
  s.erase(0, s.find_first_not_of(space));
  s.erase(s.find_last_not_of(space) + 1);
  return s;
}

// The value of the first "key<sep>value" line of a text file, or "" if absent.
std::string lookup(const std::string& file, const std::string& key, char sep) {
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    size_t at = line.find(sep);
    if (at != std::string::npos && trim(line.substr(0, at)) == key)
      return trim(line.substr(at + 1));
  }
  return {};
}

json or_null(const std::string& s) { return s.empty() ? json() : json(s); }

// Standard output of a shell command (trimmed), or "" if it fails.
std::string run(const std::string& command) {
  std::string out;
  if (FILE* pipe = ::popen(command.c_str(), "r")) {
    char buffer[256];
    while (std::fgets(buffer, sizeof buffer, pipe)) out += buffer;
    if (::pclose(pipe) != 0) return {};
  }
  return trim(out);
}

std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

json git_description() {
  const std::string git = "git -C " + shell_quote(DOFCACHE_SOURCE_DIR);
  std::string commit = run(git + " rev-parse HEAD 2>/dev/null");
  if (commit.empty()) return json();
  // Uncommitted changes to tracked files make the commit alone an incomplete description. The
  // benchmarks' own outputs (results, figures) do not: a run rewrites them before it records.
  bool dirty = !run(git +
                    " status --porcelain --untracked-files=no -- . ':!bench/results' ':!docs/images'"
                    " 2>/dev/null")
                    .empty();
  return {{"commit", commit}, {"dirty", dirty}};
}

json build_description() {
#ifdef NDEBUG
  const bool ndebug = true;
#else
  const bool ndebug = false;
#endif
#ifdef __OPTIMIZE__
  const bool optimized = true;
#else
  const bool optimized = false;
#endif
  // CMake does not pass the build type to the compiler; infer it from what it controls.
  const char* type = optimized ? (ndebug ? "Release" : "optimized with assertions") : "Debug";
  return {{"type", type}, {"optimized", optimized}, {"assertions", !ndebug}};
}

json compiler_description() {
#if defined(__clang__)
  const char* name = "clang";
#elif defined(__GNUC__)
  const char* name = "gcc";
#else
  const char* name = "unknown";
#endif
  return {{"name", name}, {"version", __VERSION__}, {"cplusplus", __cplusplus}};
}

std::string utc_now() {
  std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

bool is_flat_row(const json& row) {
  if (!row.is_object()) return false;
  return std::all_of(row.begin(), row.end(), [](const json& v) { return v.is_primitive(); });
}

bool is_flat_rows(const json& rows) {
  return rows.is_array() && std::all_of(rows.begin(), rows.end(), is_flat_row);
}

std::string csv_field(const json& v) {
  std::string text;
  if (v.is_null())
    return {};
  else if (v.is_string())
    text = v.get<std::string>();
  else
    text = v.dump();  // numbers (shortest exact form) and booleans
  if (text.find_first_of(",\"\r\n") == std::string::npos && trim(text) == text) return text;
  std::string quoted = "\"";
  for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

void write_text(const std::string& path, const std::string& text) {
  write_bytes_atomically(path, text);
}

}  // namespace

json machine_description() {
  json m;
  m["cpu"] = or_null(lookup("/proc/cpuinfo", "model name", ':'));
  m["logical_cores"] = std::thread::hardware_concurrency();
  // What TBB will use: fewer than the cores if the process is restricted (affinity, cgroups).
  m["threads_available"] = tbb::info::default_concurrency();
  std::string mem_kb = lookup("/proc/meminfo", "MemTotal", ':');  // "16318412 kB"
  if (!mem_kb.empty()) {
    double bytes = std::strtod(mem_kb.c_str(), nullptr) * 1024.0;
    m["memory_bytes"] = static_cast<std::uint64_t>(bytes);
    m["memory_gib"] = std::round(bytes / (1 << 30) * 10.0) / 10.0;
  } else {
    m["memory_bytes"] = nullptr;
    m["memory_gib"] = nullptr;
  }
  std::string os = lookup("/etc/os-release", "PRETTY_NAME", '=');
  os.erase(std::remove(os.begin(), os.end(), '"'), os.end());
  m["os"] = or_null(os);
  struct utsname u {};
  if (::uname(&u) == 0)
    m["kernel"] = std::string(u.sysname) + " " + u.release + " " + u.machine;
  else
    m["kernel"] = nullptr;
  char host[256] = {};
  m["hostname"] = ::gethostname(host, sizeof host - 1) == 0 ? json(host) : json();
  m["compiler"] = compiler_description();
  m["build"] = build_description();
  m["date_utc"] = utc_now();
  m["git"] = git_description();
  return m;
}

std::string results_dir() {
  const char* env = std::getenv("DOFCACHE_BENCH_RESULTS");
  fs::path dir = env && *env ? fs::path(env) : fs::path(DOFCACHE_SOURCE_DIR) / "bench" / "results";
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    throw Error("cannot create the results directory '" + dir.string() + "': " + ec.message());
  return dir.string();
}

std::string rows_to_csv(const json& rows, const std::vector<std::string>& column_order) {
  if (!is_flat_rows(rows))
    throw Error("CSV needs an array of flat objects (strings, numbers, booleans, null)");
  std::vector<std::string> columns;
  std::set<std::string> seen;
  for (const std::string& key : column_order)
    if (seen.insert(key).second) columns.push_back(key);
  for (const json& row : rows)
    for (auto it = row.begin(); it != row.end(); ++it)
      if (seen.insert(it.key()).second) columns.push_back(it.key());
  std::string csv;
  for (size_t c = 0; c < columns.size(); ++c) csv += (c ? "," : "") + csv_field(columns[c]);
  csv += "\n";
  for (const json& row : rows) {
    for (size_t c = 0; c < columns.size(); ++c) {
      auto it = row.find(columns[c]);
      csv += (c ? "," : "") + (it == row.end() ? std::string() : csv_field(*it));
    }
    csv += "\n";
  }
  return csv;
}

std::string results_name_problem(const std::string& name) {
  if (name.empty()) return "the results name is empty";
  if (name.size() > 100) return "the results name is longer than 100 characters";
  // A leading '.' would hide the files (or be "." / ".."); a leading '-' reads as a flag.
  if (name[0] == '.' || name[0] == '-')
    return "the results name '" + name + "' starts with '" + name[0] + "'";
  for (char c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '.' && c != '-')
      return "the results name '" + name + "' has a character other than A-Z a-z 0-9 _ . -";
  return {};
}

std::string write_results(const std::string& name, const json& results) {
  if (std::string problem = results_name_problem(name); !problem.empty()) throw Error(problem);
  const fs::path dir = results_dir();
  const std::string json_path = (dir / (name + ".json")).string();
  json doc = {{"machine", machine_description()}, {"results", results}};
  write_text(json_path, doc.dump(2) + "\n");

  if (results.is_object() && results.contains("rows")) {
    const json& rows = results["rows"];
    std::vector<std::string> order;
    if (auto it = results.find("columns"); it != results.end() && it->is_array())
      for (const json& key : *it)
        if (key.is_string()) order.push_back(key.get<std::string>());
    if (is_flat_rows(rows))
      write_text((dir / (name + ".csv")).string(), rows_to_csv(rows, order));
    else
      std::cerr << name << ": results[\"rows\"] is not an array of flat objects; no CSV written\n";
  }
  return json_path;
}

namespace {

// Parses as the widest type of its kind, so that an int too large to store reads as out of range.
template <class Wide>
CLI::Validator range_validator(Wide min, Wide max, const char* kind, const char* what) {
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        Wide value{};
        if (!CLI::detail::lexical_cast(text, value))
          return fmt::format("'{}' is not {} (expected {} to {})", text, what, min, max);
        if (value < min || value > max)
          return fmt::format("{} is out of range (expected {} to {})", text, min, max);
        return {};
      },
      fmt::format("{} in [{} - {}]", kind, min, max), "range");
}

// One line for every parse error, as the dofcache CLI prints them.
void set_failure_message(CLI::App& app) {
  app.failure_message([](const CLI::App* a, const CLI::Error& e) {
    return a->get_name() + ": error: " + e.what() + " (see --help)\n";
  });
}

// Shows each option's default in --help: what its variable holds before parsing.
void capture_defaults(CLI::App& app) {
  for (CLI::Option* opt : app.get_options())
    if (opt->get_default_str().empty()) opt->capture_default_str();
}

[[noreturn]] void usage_error(const std::string& program, const std::string& message) {
  std::fprintf(stderr, "%s: error: %s (see --help)\n", program.c_str(), message.c_str());
  std::exit(2);
}

// What Google Benchmark was given; it keeps pointers into these for the whole run.
std::string g_program;
std::vector<std::string> g_benchmark_args;
std::vector<char*> g_benchmark_argv;

// Google Benchmark calls this, then exit(0), for a flag value it rejects (e.g.
// --benchmark_format=xml): made a usage error like the others.
void benchmark_rejected() {
  std::string given;
  for (size_t i = 1; i < g_benchmark_args.size(); ++i) given += " " + g_benchmark_args[i];
  usage_error(g_program, "Google Benchmark rejected a flag value, given:" + given);
}

}  // namespace

CLI::Validator in_range(int min, int max) {
  return range_validator<long long>(min, max, "INT", "an integer");
}

CLI::Validator in_range(double min, double max) {
  return range_validator(min, max, "FLOAT", "a number");
}

void add_common_options(CLI::App& app, int& width, int& threads, std::string& results) {
  app.add_option("--width", width, "Image width in pixels (the height follows the camera)")
      ->check(in_range(1, 16384));
  app.add_option("--threads", threads, "Render threads (0: all cores)")->check(in_range(0, 4096));
  add_results_option(app, results);
}

CLI::Option* add_results_option(CLI::App& app, std::string& results) {
  return app
      .add_option("--results", results,
                  "Results name: writes NAME.json and NAME.csv to bench/results/ (or to "
                  "$DOFCACHE_BENCH_RESULTS); letters, digits, '_', '.', '-'")
      ->type_name("NAME")
      ->check(CLI::Validator([](std::string& name) { return results_name_problem(name); }, "",
                             "results name"));
}

CLI::Option* add_count_option(CLI::App& app, const std::string& name, int& value,
                              const std::string& help, int minimum) {
  return app.add_option(name, value, help)->check(in_range(minimum, 1 << 20));
}

std::string scene_path(const std::string& file) {
  return std::string(DOFCACHE_SOURCE_DIR) + "/scenes/" + file;
}

CLI::Option* add_rays_option(CLI::App& app, int& rays) {
  return app.add_option("--rays", rays, "Camera rays generated per measurement")
      ->capture_default_str()
      ->check(CLI::Range(1, 1 << 30));
}

namespace {
// What a timing loop adds up from its rays (so the compiler keeps them) and how many pass.
struct RayTally {
  float sum = 0.0f;
  int passed = 0;
  void add(const render::LensSample& s) {
    sum += s.ray.direction.x + s.ray.origin.y + s.weight;
    passed += s.weight > 0.0f;
  }
  RayTiming finish(const Stopwatch& clock, int count, float* sink) const {
    RayTiming t;
    t.seconds = clock.seconds();
    t.passed = static_cast<double>(passed) / count;
    *sink += sum;
    return t;
  }
};
}  // namespace

RayTiming time_camera_rays(const render::ThinLensCamera& camera, int count, bool banded,
                           float* sink) {
  const render::Sobol2D film(1), lens(2);
  const Stopwatch clock;
  RayTally tally;
  const int w = camera.width(), h = camera.height();
  for (int i = 0; i < count; ++i) {
    const glm::vec2 f = film(static_cast<std::uint32_t>(i));
    tally.add(camera.lens_ray({f.x * w, f.y * h}, lens(static_cast<std::uint32_t>(i)),
                              banded ? i % 3 : -1));
  }
  return tally.finish(clock, count, sink);
}

RayTiming time_camera_rays_batched(const render::ThinLensCamera& camera, int count, bool banded,
                                   float* sink) {
  const render::Sobol2D film(1), lens(2);
  constexpr int kBlock = 16;
  glm::vec2 films[kBlock], us[kBlock];
  int bands[kBlock];
  render::LensSample rays[kBlock];
  const Stopwatch clock;
  RayTally tally;
  const int w = camera.width(), h = camera.height();
  for (int i0 = 0; i0 < count; i0 += kBlock) {
    const int n = std::min(kBlock, count - i0);
    for (int j = 0; j < n; ++j) {
      const int i = i0 + j;
      const glm::vec2 f = film(static_cast<std::uint32_t>(i));
      films[j] = {f.x * w, f.y * h};
      us[j] = lens(static_cast<std::uint32_t>(i));
      bands[j] = banded ? i % 3 : -1;
    }
    camera.lens_rays(static_cast<std::size_t>(n), films, us, bands, rays);
    for (int j = 0; j < n; ++j) tally.add(rays[j]);
  }
  return tally.finish(clock, count, sink);
}

CLI::Option* add_scene_option(CLI::App& app, std::vector<std::string>& scenes) {
  auto in_scenes_dir = [](std::string& file) -> std::string {
    if (fs::is_regular_file(scene_path(file))) return {};
    return "no scene file '" + file + "' in " + DOFCACHE_SOURCE_DIR + "/scenes";
  };
  return app
      .add_option("--scene", scenes,
                  "A scene file in scenes/ (repeat for several); replaces the default list")
      ->type_name("FILE")
      ->check(CLI::Validator(in_scenes_dir, "", "scene file"));
}

void parse_command_line(CLI::App& app, int argc, char** argv) {
  set_failure_message(app);
  capture_defaults(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    std::exit(app.exit(e) == 0 ? 0 : 2);  // help, or the one-line error
  }
}

void parse_benchmark_command_line(CLI::App& app, int argc, char** argv) {
  set_failure_message(app);
  capture_defaults(app);
  // Google Benchmark reads its own flags; CLI11 only has to let them through.
  app.allow_extras();
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    app.exit(e);
    std::printf("Google Benchmark flags (--benchmark_NAME=VALUE, passed through):\n");
    benchmark::PrintDefaultHelp();
    std::exit(0);
  } catch (const CLI::ParseError& e) {
    std::exit(app.exit(e) == 0 ? 0 : 2);
  }
  g_program = app.get_name();
  g_benchmark_args = {argv[0]};
  for (const std::string& extra : app.remaining()) {
    if (extra.rfind("--benchmark_", 0) != 0 && extra.rfind("--v=", 0) != 0) {
      // "--benchmark_filter lookup": Google Benchmark reads no value after a space.
      const std::string& previous = g_benchmark_args.back();
      const bool value_of_previous = g_benchmark_args.size() > 1 &&
                                     previous.find('=') == std::string::npos;
      usage_error(g_program, "unknown argument '" + extra + "'" +
                                 (value_of_previous ? " (write " + previous + "=" + extra + ")"
                                                    : ""));
    }
    g_benchmark_args.push_back(extra);
  }
  for (std::string& a : g_benchmark_args) g_benchmark_argv.push_back(a.data());
  g_benchmark_argv.push_back(nullptr);
  int count = static_cast<int>(g_benchmark_args.size());
  // Google Benchmark explains a malformed value on std::cerr; caught to make it the one line.
  std::ostringstream complaint;
  std::streambuf* cerr_buffer = std::cerr.rdbuf(complaint.rdbuf());
  benchmark::Initialize(&count, g_benchmark_argv.data(), benchmark_rejected);
  std::cerr.rdbuf(cerr_buffer);
  std::string said = trim(complaint.str());
  // What it left in argv is what it did not accept: an unknown flag or a malformed value.
  if (count > 1) {
    if (said.empty() || said.find('\n') != std::string::npos)
      said = "Google Benchmark did not accept '" + std::string(g_benchmark_argv[1]) + "'";
    usage_error(g_program, said);
  }
  if (!said.empty()) std::cerr << said << '\n';
}

int run_guarded(const CLI::App& app, const std::function<int()>& body) {
  try {
    return body();
  } catch (const std::exception& e) {
    std::fflush(stdout);
    std::fprintf(stderr, "%s: error: %s\n", app.get_name().c_str(), e.what());
    return 1;
  }
}

Table::Table(std::vector<std::string> header, int default_precision)
    : header_(std::move(header)), default_precision_(default_precision) {}

void Table::add_row(std::vector<Cell> row) {
  if (row.size() != header_.size())
    throw std::invalid_argument(
        fmt::format("table row has {} cells, the header {}", row.size(), header_.size()));
  rows_.push_back(std::move(row));
}

std::string Table::format(const Cell& cell) const {
  if (cell.kind != Cell::Kind::Real) return cell.text;
  if (std::isnan(cell.value)) return "nan";
  if (std::isinf(cell.value)) return cell.value > 0 ? "inf" : "-inf";
  int precision = cell.precision >= 0 ? cell.precision : default_precision_;
  return fmt::format("{:.{}f}", cell.value, precision);
}

std::string Table::str() const {
  std::vector<size_t> width(header_.size());
  for (size_t c = 0; c < header_.size(); ++c) width[c] = header_[c].size();
  std::vector<std::vector<std::string>> text;
  for (const auto& row : rows_) {
    text.emplace_back();
    for (size_t c = 0; c < row.size(); ++c) {
      text.back().push_back(format(row[c]));
      width[c] = std::max(width[c], text.back().back().size());
    }
  }
  auto numeric = [](const Cell& cell) {
    return cell.kind == Cell::Kind::Integer || cell.kind == Cell::Kind::Real;
  };
  std::string out;
  auto line = [&](const std::vector<std::string>& cells, const std::vector<Cell>* kinds) {
    std::string l;
    for (size_t c = 0; c < cells.size(); ++c) {
      if (c) l += "  ";
      bool right = kinds && numeric((*kinds)[c]);
      l += right ? fmt::format("{:>{}}", cells[c], width[c])
                 : fmt::format("{:<{}}", cells[c], width[c]);
    }
    l.erase(l.find_last_not_of(' ') + 1);
    out += l + "\n";
  };
  line(header_, nullptr);
  std::vector<std::string> rule;
  for (size_t w : width) rule.push_back(std::string(w, '-'));
  line(rule, nullptr);
  for (size_t r = 0; r < rows_.size(); ++r) line(text[r], &rows_[r]);
  return out;
}

void Table::print(std::FILE* out) const {
  std::string s = str();
  std::fwrite(s.data(), 1, s.size(), out);
  std::fflush(out);
}

std::string write_table(const std::string& name, const Table& table, json results) {
  results["columns"] = table.header();
  results["rows"] = table.to_json();
  const std::string path = write_results(name, results);
  std::printf("wrote %s\n", path.c_str());
  return path;
}

json Table::to_json() const {
  json rows = json::array();
  for (const auto& row : rows_) {
    json obj = json::object();
    for (size_t c = 0; c < row.size(); ++c) {
      const Cell& cell = row[c];
      switch (cell.kind) {
        case Cell::Kind::Text:
          obj[header_[c]] = cell.text;
          break;
        case Cell::Kind::Integer:
          obj[header_[c]] = json::parse(cell.text);
          break;
        case Cell::Kind::Boolean:
          obj[header_[c]] = cell.text == "true";
          break;
        case Cell::Kind::Real:
          obj[header_[c]] = std::isfinite(cell.value) ? json(cell.value) : json();
          break;
      }
    }
    rows.push_back(std::move(obj));
  }
  return rows;
}

image::Image cached_reference(const std::string& key, const std::function<image::Image()>& render) {
  std::filesystem::path dir = std::filesystem::path(results_dir()) / "references";
  std::filesystem::create_directories(dir);
  // The estimator revision is part of the name: a reference from older code is never reused.
  std::filesystem::path file =
      dir / (key + "_r" + std::to_string(render::kEstimatorRevision) + ".exr");
  if (std::filesystem::exists(file)) return image::read_image(file.string());
  std::fprintf(stderr, "rendering reference %s (once; kept in %s)\n", key.c_str(), dir.c_str());
  image::Image img = render();
  image::write_image(file.string(), img);
  return img;
}

render::RenderSettings camera_settings(const scene::Scene& scene, const scene::Accel& accel,
                                       const scene::Camera& camera, int width, int spp,
                                       int threads, const std::string& lens_file) {
  // The benchmarks' base: a plain integrator render (no cache, uniform sampling, the renderer's
  // own cache tuning), which each benchmark varies, resolved as every front end's request is.
  request::RenderRequest q = request::default_request(request::Kind::Image);
  q.camera = camera.name;
  q.width = width;
  q.spp = spp;
  q.threads = threads;
  q.cache = cache::kNoCache;
  q.adaptive = request::Choice::Off;
  q.cache_settings = render::CacheSettings{};
  q.quiet = true;
  q.out.clear();  // the benchmarks write their own files
  q.lens.real.file = lens_file;
  return request::resolve(q, scene, accel, camera).settings;
}

image::Image converged_reference(const std::string& scene_name, const scene::Scene& scene,
                                 const scene::Accel& accel, const scene::Camera& camera,
                                 const render::RenderSettings& base, int spp) {
  std::string key = scene_name + "_" + std::to_string(base.width) + "x" +
                    std::to_string(base.height) + "_" + std::to_string(spp) + "spp_" +
                    std::to_string(scene.content_hash % 100000);
  if (const lens::MountedLens& m = base.real_lens)  // a real lens images another picture
    key += "_" + std::filesystem::path(m.source).stem().string() + "_f" +
           std::to_string(static_cast<int>(std::lround(m.lens->fstop() * 100)));
  return cached_reference(key, [&] {
    render::RenderSettings r = base;
    r.spp = spp;
    r.seed = 1000003;  // independent of the measured renders' noise
    r.cache.cache = nullptr;
    r.progress = Progress::Display::Auto;
    r.progress_label = "reference " + scene_name;
    return render::render(scene, accel, camera, r).color;
  });
}

}  // namespace dofcache::bench
