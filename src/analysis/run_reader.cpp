// Implementation of run_reader.h.
#include "analysis/run_reader.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <numbers>
#include <string_view>

namespace granary::analysis {
namespace {

std::string where(const std::filesystem::path& file, std::int64_t line) {
  return file.string() + ":" + std::to_string(line);
}

void split(std::string_view s, char sep, std::vector<std::string_view>& out) {
  out.clear();
  if (sep == ' ') {
    std::size_t i = 0;
    while (i < s.size()) {
      while (i < s.size() && (s[i] == ' ' || s[i] == '\t' || s[i] == '\r')) ++i;
      const std::size_t start = i;
      while (i < s.size() && s[i] != ' ' && s[i] != '\t' && s[i] != '\r') ++i;
      if (i > start) out.push_back(s.substr(start, i - start));
    }
    return;
  }
  std::size_t start = 0;
  for (;;) {
    std::size_t end = s.find(sep, start);
    std::string_view field = s.substr(start, end == std::string_view::npos ? std::string_view::npos : end - start);
    while (!field.empty() && (field.back() == '\r' || field.back() == ' ')) field.remove_suffix(1);
    while (!field.empty() && field.front() == ' ') field.remove_prefix(1);
    out.push_back(field);
    if (end == std::string_view::npos) break;
    start = end + 1;
  }
}

bool to_double(std::string_view s, double& v) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  return ec == std::errc() && ptr == s.data() + s.size();
}
bool to_int(std::string_view s, std::int64_t& v) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec == std::errc() && ptr == s.data() + s.size()) return true;
  // Some writers print integers as "12.0".
  double d = 0.0;
  if (to_double(s, d) && std::floor(d) == d && std::abs(d) < 9e15) {
    v = static_cast<std::int64_t>(d);
    return true;
  }
  return false;
}

int column(const std::vector<std::string>& names, const std::string& name) {
  auto it = std::find(names.begin(), names.end(), name);
  return it == names.end() ? -1 : static_cast<int>(it - names.begin());
}

}  // namespace

// ---- summary.json -----------------------------------------------------------------------

Summary parse_summary(const nlohmann::json& j, const std::string& file) {
  if (!j.is_object()) throw ReadError(file + ": summary is not a JSON object");
  Summary s;
  s.raw = j;
  try {
    s.engine = j.value("engine", "");
    s.engine_version = j.value("engine_version", "");
    s.granary_commit = j.value("granary_commit", "");
    s.run_id = j.value("run_id", "");
    s.end_reason = j.value("end_reason", "");
    s.bodies = j.value("bodies", 0);
    s.exited = j.value("exited", 0);
    s.remaining = j.value("remaining", s.bodies - s.exited);
    if (j.contains("exits_per_outlet")) s.exits_per_outlet = j.at("exits_per_outlet").get<std::vector<int>>();
    s.t_end = j.value("t_end", 0.0);
    if (j.contains("spec")) s.spec = j.at("spec");
  } catch (const nlohmann::json::exception& e) {
    throw ReadError(file + ": " + e.what());
  }
  return s;
}

Summary read_summary(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw ReadError(file.string() + ": cannot open");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw ReadError(file.string() + ": not valid JSON: " + e.what());
  }
  return parse_summary(j, file.string());
}

// ---- events.csv -------------------------------------------------------------------------

std::vector<ExitEvent> read_events(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw ReadError(file.string() + ": cannot open");
  std::string line;
  std::int64_t line_no = 0;
  std::vector<std::string_view> f;
  std::vector<std::string> names;
  while (names.empty() && std::getline(in, line)) {
    ++line_no;
    split(line, ',', f);
    if (f.size() == 1 && f[0].empty()) continue;
    for (auto n : f) names.emplace_back(n);
  }
  std::vector<ExitEvent> events;
  if (names.empty()) return events;  // empty file: no exits yet
  const int c_time = column(names, "time");
  const int c_body = column(names, "body");
  const int c_shape = column(names, "shape");
  const int c_mass = column(names, "mass");
  const int c_outlet = column(names, "outlet");
  if (c_time < 0) throw ReadError(where(file, line_no) + ": header has no 'time' column (got '" + line + "')");
  const std::size_t need = static_cast<std::size_t>(std::max({c_time, c_body, c_shape, c_mass, c_outlet})) + 1;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line == "\r") continue;
    split(line, ',', f);
    if (f.size() < need)
      throw ReadError(where(file, line_no) + ": expected " + std::to_string(names.size()) + " fields, got " +
                      std::to_string(f.size()) + " ('" + line + "')");
    ExitEvent e;
    std::int64_t iv = 0;
    if (!to_double(f[static_cast<std::size_t>(c_time)], e.time) || !std::isfinite(e.time))
      throw ReadError(where(file, line_no) + ": time '" + std::string(f[static_cast<std::size_t>(c_time)]) +
                      "' is not a number");
    if (c_body >= 0) {
      if (!to_int(f[static_cast<std::size_t>(c_body)], iv))
        throw ReadError(where(file, line_no) + ": body '" + std::string(f[static_cast<std::size_t>(c_body)]) +
                        "' is not an integer");
      e.body = iv;
    }
    if (c_shape >= 0) e.shape = std::string(f[static_cast<std::size_t>(c_shape)]);
    e.mass = std::nan("");
    if (c_mass >= 0 && !to_double(f[static_cast<std::size_t>(c_mass)], e.mass))
      throw ReadError(where(file, line_no) + ": mass '" + std::string(f[static_cast<std::size_t>(c_mass)]) +
                      "' is not a number");
    if (c_outlet >= 0) {
      if (!to_int(f[static_cast<std::size_t>(c_outlet)], iv) || iv < 0)
        throw ReadError(where(file, line_no) + ": outlet '" + std::string(f[static_cast<std::size_t>(c_outlet)]) +
                        "' is not an outlet index");
      e.outlet = static_cast<int>(iv);
    }
    events.push_back(std::move(e));
  }
  std::stable_sort(events.begin(), events.end(),
                   [](const ExitEvent& a, const ExitEvent& b) { return a.time < b.time; });
  return events;
}

// ---- bodies -----------------------------------------------------------------------------

std::vector<Body> bodies_of(const std::vector<Disc>& discs) {
  std::vector<std::size_t> order(discs.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return discs[a].mol != discs[b].mol ? discs[a].mol < discs[b].mol : discs[a].id < discs[b].id;
  });
  std::vector<Body> bodies;
  std::size_t i = 0;
  while (i < order.size()) {
    std::size_t j = i;
    while (j < order.size() && discs[order[j]].mol == discs[order[i]].mol) ++j;
    Body b;
    b.id = discs[order[i]].mol;
    b.type = discs[order[i]].type;
    b.n_discs = static_cast<int>(j - i);
    for (std::size_t k = i; k < j; ++k) {
      const Disc& d = discs[order[k]];
      b.mass += d.mass;
      b.x += d.mass * d.x;
      b.y += d.mass * d.y;
      b.vx += d.mass * d.vx;
      b.vy += d.mass * d.vy;
      b.area += std::numbers::pi * d.radius * d.radius;
    }
    if (b.mass > 0.0) {
      b.x /= b.mass;
      b.y /= b.mass;
      b.vx /= b.mass;
      b.vy /= b.mass;
    }
    for (std::size_t k = i; k < j; ++k) {
      const Disc& d = discs[order[k]];
      const double dx = d.x - b.x, dy = d.y - b.y;
      b.inertia += d.mass * (dx * dx + dy * dy) + 0.4 * d.mass * d.radius * d.radius;
    }
    b.omega = discs[order[i]].omega;
    if (j - i >= 2) {
      const Disc& first = discs[order[i]];
      const Disc& last = discs[order[j - 1]];
      b.theta = std::atan2(last.y - first.y, last.x - first.x);
    }
    bodies.push_back(b);
    i = j;
  }
  return bodies;
}

// ---- frames.dump ------------------------------------------------------------------------

FrameReader::FrameReader(const std::filesystem::path& file, double density)
    : file_(file), in_(file), density_(density) {
  if (!in_) throw ReadError(file.string() + ": cannot open");
}

void FrameReader::fail(const std::string& what) const { throw ReadError(where(file_, line_no_) + ": " + what); }

bool FrameReader::next_line(std::string& line) {
  if (!std::getline(in_, line)) return false;
  ++line_no_;
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return true;
}

bool FrameReader::next(Frame& frame) {
  std::string line;
  // Skip blank lines between frames.
  do {
    if (!next_line(line)) return false;
  } while (line.find_first_not_of(" \t") == std::string::npos);
  frame = Frame();
  // LAMMPS writes ITEM: UNITS and ITEM: TIME before ITEM: TIMESTEP; run directories written
  // before Granary followed that order have TIME after it, which the item loop below reads.
  while (line == "ITEM: UNITS" || line == "ITEM: TIME") {
    const std::string item = line;
    if (!next_line(line)) return false;
    if (item == "ITEM: TIME" && !to_double(std::string_view(line), frame.time)) fail("time '" + line + "' is not a number");
    if (!next_line(line)) return false;
  }
  if (line.rfind("ITEM: TIMESTEP", 0) != 0) fail("expected 'ITEM: TIMESTEP', got '" + line + "'");
  std::int64_t n_atoms = -1;
  std::vector<std::string_view> f;
  if (!next_line(line)) return false;  // truncated frame at the end: stop quietly
  if (!to_int(std::string_view(line), frame.timestep)) fail("timestep '" + line + "' is not an integer");
  // Header items until ITEM: ATOMS; unknown items (one value line) are skipped.
  for (;;) {
    if (!next_line(line)) return false;
    if (line.rfind("ITEM: ", 0) != 0) fail("expected an 'ITEM:' line, got '" + line + "'");
    if (line.rfind("ITEM: ATOMS", 0) == 0) break;
    if (line.rfind("ITEM: TIMESTEP", 0) == 0) fail("'ITEM: TIMESTEP' before the atoms of the previous frame");
    const std::string item = line;
    if (item.rfind("ITEM: BOX BOUNDS", 0) == 0) {
      for (int k = 0; k < 3; ++k) {
        if (!next_line(line)) return false;
        split(line, ' ', f);
        if (f.size() < 2 || !to_double(f[0], frame.box[k][0]) || !to_double(f[1], frame.box[k][1]))
          fail("box bounds line '" + line + "' is not two numbers");
      }
      continue;
    }
    if (!next_line(line)) return false;
    if (item == "ITEM: NUMBER OF ATOMS") {
      if (!to_int(std::string_view(line), n_atoms) || n_atoms < 0) fail("number of atoms '" + line + "' is not a count");
    } else if (item == "ITEM: TIME") {
      if (!to_double(std::string_view(line), frame.time)) fail("time '" + line + "' is not a number");
    }
  }
  if (n_atoms < 0) fail("frame has no 'ITEM: NUMBER OF ATOMS'");
  std::vector<std::string> names;
  {
    split(std::string_view(line).substr(std::string_view("ITEM: ATOMS").size()), ' ', f);
    for (auto n : f) names.emplace_back(n);
  }
  const int c_id = column(names, "id"), c_mol = column(names, "mol"), c_type = column(names, "type");
  const int c_x = column(names, "x"), c_y = column(names, "y"), c_r = column(names, "radius");
  const int c_m = column(names, "mass"), c_vx = column(names, "vx"), c_vy = column(names, "vy");
  const int c_w = column(names, "omegaz");
  for (const char* req : {"id", "mol", "x", "y"})
    if (column(names, req) < 0) fail(std::string("atoms header has no '") + req + "' column ('" + line + "')");
  std::size_t need = 0;
  for (int c : {c_id, c_mol, c_type, c_x, c_y, c_r, c_m, c_vx, c_vy, c_w})
    need = std::max(need, static_cast<std::size_t>(c + 1));
  frame.discs.reserve(static_cast<std::size_t>(n_atoms));
  for (std::int64_t a = 0; a < n_atoms; ++a) {
    if (!next_line(line)) {
      frame.discs.clear();
      return false;  // truncated at the end of the file
    }
    split(line, ' ', f);
    if (f.size() < need && in_.eof()) {
      frame.discs.clear();
      return false;  // last line cut short: an engine still writing
    }
    if (f.size() < need)
      fail("atom row has " + std::to_string(f.size()) + " fields, the header names " + std::to_string(names.size()));
    Disc d;
    std::int64_t iv = 0;
    auto num = [&](int c, double& out, const char* what) {
      if (c < 0) return;
      if (!to_double(f[static_cast<std::size_t>(c)], out))
        fail(std::string(what) + " '" + std::string(f[static_cast<std::size_t>(c)]) + "' is not a number");
    };
    if (!to_int(f[static_cast<std::size_t>(c_id)], d.id)) fail("id '" + std::string(f[static_cast<std::size_t>(c_id)]) + "' is not an integer");
    if (!to_int(f[static_cast<std::size_t>(c_mol)], d.mol)) fail("mol '" + std::string(f[static_cast<std::size_t>(c_mol)]) + "' is not an integer");
    if (c_type >= 0) {
      if (!to_int(f[static_cast<std::size_t>(c_type)], iv)) fail("type '" + std::string(f[static_cast<std::size_t>(c_type)]) + "' is not an integer");
      d.type = static_cast<int>(iv);
    }
    num(c_x, d.x, "x");
    num(c_y, d.y, "y");
    num(c_r, d.radius, "radius");
    d.mass = density_ * std::numbers::pi * d.radius * d.radius;
    num(c_m, d.mass, "mass");
    num(c_vx, d.vx, "vx");
    num(c_vy, d.vy, "vy");
    num(c_w, d.omega, "omegaz");
    frame.discs.push_back(d);
  }
  return true;
}

// ---- contacts.dump ----------------------------------------------------------------------

ContactReader::ContactReader(const std::filesystem::path& file) : file_(file), in_(file) {
  if (!in_) throw ReadError(file.string() + ": cannot open");
}

void ContactReader::fail(const std::string& what) const { throw ReadError(where(file_, line_no_) + ": " + what); }

bool ContactReader::next(ContactFrame& frame) {
  std::string line;
  std::vector<std::string_view> f;
  auto get = [&]() {
    if (!std::getline(in_, line)) return false;
    ++line_no_;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  };
  do {
    if (!get()) return false;
  } while (line.find_first_not_of(" \t") == std::string::npos);
  frame = ContactFrame();
  while (line == "ITEM: UNITS" || line == "ITEM: TIME") {  // as in FrameReader::next
    const std::string item = line;
    if (!get()) return false;
    if (item == "ITEM: TIME" && !to_double(std::string_view(line), frame.time)) fail("time '" + line + "' is not a number");
    if (!get()) return false;
  }
  if (line != "ITEM: TIMESTEP") fail("expected 'ITEM: TIMESTEP', got '" + line + "'");
  std::int64_t n = -1;
  if (!get()) return false;
  if (!to_int(std::string_view(line), frame.timestep)) fail("timestep '" + line + "' is not an integer");
  for (;;) {
    if (!get()) return false;
    if (line.rfind("ITEM: ENTRIES", 0) == 0) break;
    if (line.rfind("ITEM: ", 0) != 0) fail("expected an 'ITEM:' line, got '" + line + "'");
    const std::string item = line;
    if (item.rfind("ITEM: BOX BOUNDS", 0) == 0) {
      for (int k = 0; k < 3; ++k)
        if (!get()) return false;
      continue;
    }
    if (!get()) return false;
    if (item == "ITEM: TIME") {
      if (!to_double(std::string_view(line), frame.time)) fail("time '" + line + "' is not a number");
    } else if (item == "ITEM: NUMBER OF ENTRIES") {
      if (!to_int(std::string_view(line), n) || n < 0) fail("number of entries '" + line + "' is not a count");
    }
  }
  if (n < 0) fail("frame has no 'ITEM: NUMBER OF ENTRIES'");
  std::vector<std::string> names;
  split(std::string_view(line).substr(std::string_view("ITEM: ENTRIES").size()), ' ', f);
  for (auto s : f) names.emplace_back(s);
  static const char* kCols[] = {"body_i", "body_j", "xi", "yi", "xj", "yj", "cx", "cy", "fx", "fy"};
  int cols[10];
  std::size_t need = 0;
  for (int k = 0; k < 10; ++k) {
    cols[k] = column(names, kCols[k]);
    if (cols[k] < 0) fail(std::string("entries header has no '") + kCols[k] + "' column ('" + line + "')");
    need = std::max(need, static_cast<std::size_t>(cols[k] + 1));
  }
  frame.contacts.reserve(static_cast<std::size_t>(n));
  for (std::int64_t r = 0; r < n; ++r) {
    if (!get()) {
      frame.contacts.clear();
      return false;
    }
    split(line, ' ', f);
    if (f.size() < need && in_.eof()) {
      frame.contacts.clear();
      return false;
    }
    if (f.size() < need) fail("contact row has " + std::to_string(f.size()) + " fields, expected " + std::to_string(names.size()));
    ContactRow c;
    auto idx = [&](int k) { return f[static_cast<std::size_t>(cols[k])]; };
    if (!to_int(idx(0), c.body_i) || !to_int(idx(1), c.body_j)) fail("body ids in '" + line + "' are not integers");
    double* out[8] = {&c.xi, &c.yi, &c.xj, &c.yj, &c.cx, &c.cy, &c.fx, &c.fy};
    for (int k = 0; k < 8; ++k)
      if (!to_double(idx(k + 2), *out[k])) fail(std::string(kCols[k + 2]) + " '" + std::string(idx(k + 2)) + "' is not a number");
    frame.contacts.push_back(c);
  }
  return true;
}

// ---- run directory ----------------------------------------------------------------------

RunData read_run(const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  if (!fs::is_directory(dir)) throw ReadError(dir.string() + ": run directory does not exist");
  RunData r;
  r.dir = dir;
  r.done = fs::exists(dir / "DONE");
  if (fs::exists(dir / "summary.json")) {
    r.summary = read_summary(dir / "summary.json");
    r.has_summary = true;
  }
  if (fs::exists(dir / "run.json")) {
    std::ifstream in(dir / "run.json");
    try {
      r.spec = nlohmann::json::parse(in);
    } catch (const nlohmann::json::exception& e) {
      throw ReadError((dir / "run.json").string() + ": not valid JSON: " + e.what());
    }
  } else if (r.has_summary) {
    r.spec = r.summary.spec;
  }
  if (fs::exists(dir / "events.csv")) r.events = read_events(dir / "events.csv");
  r.has_frames = fs::exists(dir / "frames.dump");
  r.has_contacts = fs::exists(dir / "contacts.dump");
  return r;
}

}  // namespace granary::analysis
