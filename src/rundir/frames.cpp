// See frames.h.
#include "rundir/frames.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string_view>

#include "rundir/dump_text.h"
#include "rundir/gzip.h"
#include "rundir/layout.h"

namespace granary::rundir {

using detail::Column;
using detail::Split;
using detail::ToDouble;
using detail::ToInt;

// ---- bodies ------------------------------------------------------------------------------

std::vector<Body> BodiesOf(const std::vector<Disc>& discs) {
  std::vector<std::size_t> order(discs.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  auto before = [&](std::size_t a, std::size_t b) {
    return discs[a].mol != discs[b].mol ? discs[a].mol < discs[b].mol : discs[a].id < discs[b].id;
  };
  // Engines write the discs of a body together and bodies in order: usually nothing to sort.
  if (!std::is_sorted(order.begin(), order.end(), before)) std::sort(order.begin(), order.end(), before);
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

// ---- writer ------------------------------------------------------------------------------

FrameWriter FrameWriter::Create(const std::filesystem::path& file, bool gzip) {
  FrameWriter w;
  if (file.extension() == ".gsd") {
    w.gsd_ = gsd::GsdFrameWriter::Create(file);
    return w;
  }
  w.file_ = OutputFile(file);
  w.gzip_ = gzip;
  // Every engine writes its frames file here, so every run directory gets the data file.
  if (file.filename() == kFramesFile || file.filename() == kFramesGzFile) {
    w.data_file_ = file.parent_path() / kFramesDataFile;
    std::filesystem::remove(w.data_file_);
  }
  return w;
}

std::string LammpsDataFile(const Frame& frame) {
  int types = 1;
  for (const Disc& d : frame.discs) types = std::max(types, d.type);
  std::string t = "LAMMPS data file: the discs of a Granary run's first frame (t = " + std::to_string(frame.time) +
                  "), for read_data before a rerun of its frames (docs/run-directory.md)\n\n";
  t += std::to_string(frame.discs.size()) + " atoms\n" + std::to_string(types) + " atom types\n\n";
  const char* axes[] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    detail::AppendG17(t, frame.box[a][0]);
    t += ' ';
    detail::AppendG17(t, frame.box[a][1]);
    t += std::string(" ") + axes[a] + "lo " + axes[a] + "hi\n";
  }
  t += "\nAtoms # sphere\n\n";
  // id type diameter density x y z: LAMMPS gives a sphere the mass density * (4/3) pi r^3
  // even in 2-D, so the density is the one that makes that the disc's own mass (rho pi r^2).
  for (const Disc& d : frame.discs) {
    detail::AppendInt(t, d.id);
    t += ' ';
    detail::AppendInt(t, d.type);
    const double density =
        d.radius > 0 ? d.mass / (4.0 / 3.0 * std::numbers::pi * d.radius * d.radius * d.radius) : 1.0;
    for (const double v : {2 * d.radius, density, d.x, d.y}) t += ' ', detail::AppendG17(t, v);
    t += " 0\n";
  }
  return t;
}

FrameWriter FrameWriter::ContinueAt(const std::filesystem::path& file, std::int64_t offset, bool gzip) {
  FrameWriter w;
  if (file.extension() == ".gsd") {
    w.gsd_ = gsd::GsdFrameWriter::ContinueAt(file, offset);
    return w;
  }
  w.file_ = OutputFile(file, offset);
  w.gzip_ = gzip;
  return w;
}

namespace {

// The block of one frame, as FrameWriter::Write writes it and FrameBytes counts it.
void WriteFrameBlock(std::FILE* f, const Frame& frame, std::string& t) {
  detail::WriteDumpHeader(f, frame.timestep, frame.time, "NUMBER OF ATOMS", frame.discs.size(), frame.box);
  std::fputs("ITEM: ATOMS id mol type x y z radius mass vx vy vz omegaz\n", f);
  // "%lld %lld %d %.10g %.10g 0 %.10g %.10g %.10g %.10g 0 %.10g\n" per disc
  std::size_t rows = 0;
  for (const Disc& d : frame.discs) {
    detail::AppendInt(t, d.id);
    t += ' ';
    detail::AppendInt(t, d.mol);
    t += ' ';
    detail::AppendInt(t, d.type);
    for (const double v : {d.x, d.y}) t += ' ', detail::AppendG10(t, v);
    t += " 0";
    for (const double v : {d.radius, d.mass, d.vx, d.vy}) t += ' ', detail::AppendG10(t, v);
    t += " 0 ";
    detail::AppendG10(t, d.omega);
    t += '\n';
    if (++rows % detail::kRowsPerWrite == 0) detail::Drain(t, f);
  }
  detail::Drain(t, f);
}

}  // namespace

void FrameWriter::Write(const Frame& frame) {
  if (gsd_.IsOpen()) return gsd_.Write(frame);
  if (!data_file_.empty()) {
    WriteAtomically(data_file_, LammpsDataFile(frame));
    data_file_.clear();
  }
  WriteBlock(file_.Get(), gzip_, [&](std::FILE* f) { WriteFrameBlock(f, frame, text_); });
}

std::int64_t FrameBytes(const Frame& frame, bool gzip) {
  std::string text;
  return BlockBytes(gzip, [&](std::FILE* f) { WriteFrameBlock(f, frame, text); });
}

// ---- reader ------------------------------------------------------------------------------

FrameReader::FrameReader(const std::filesystem::path& file, double density) : file_(file), density_(density) {
  if (gsd::IsGsdFile(file))
    gsd_ = std::make_unique<gsd::GsdFrameReader>(file);
  else
    state_ = std::make_unique<detail::DumpState>(file);
}

FrameReader::~FrameReader() = default;
FrameReader::FrameReader(FrameReader&&) noexcept = default;
FrameReader& FrameReader::operator=(FrameReader&&) noexcept = default;

bool FrameReader::NextHeader(Frame& frame) {
  if (gsd_) return gsd_->NextHeader(frame);
  detail::DumpState& st = *state_;
  frame.discs.clear();
  if (st.rows_pending && !detail::SkipDumpRows(st)) return false;
  if (!detail::ReadDumpHeader(st.lines, "NUMBER OF ATOMS", "ITEM: ATOMS", st.header)) return false;
  st.rows_pending = true;
  frame.timestep = st.header.timestep;
  frame.time = st.header.time;
  std::copy(&st.header.box[0][0], &st.header.box[0][0] + 6, &frame.box[0][0]);
  return true;
}

bool FrameReader::SkipDiscs() { return gsd_ ? gsd_->SkipDiscs() : detail::SkipDumpRows(*state_); }

bool FrameReader::ReadDiscs(Frame& frame) {
  if (gsd_) return gsd_->ReadDiscs(frame);
  detail::DumpState& st = *state_;
  detail::DumpLines& in = st.lines;
  const detail::DumpHeader& h = st.header;
  frame.discs.clear();
  if (!st.rows_pending) return false;
  st.rows_pending = false;
  const std::vector<std::string>& names = h.columns;
  const int c_id = Column(names, "id"), c_mol = Column(names, "mol"), c_type = Column(names, "type");
  const int c_x = Column(names, "x"), c_y = Column(names, "y"), c_r = Column(names, "radius");
  const int c_m = Column(names, "mass"), c_vx = Column(names, "vx"), c_vy = Column(names, "vy");
  const int c_w = Column(names, "omegaz");
  for (const char* req : {"id", "mol", "x", "y"}) {
    if (Column(names, req) >= 0) continue;
    std::string header = "ITEM: ATOMS";
    for (const auto& n : names) header += " " + n;
    in.Fail(std::string("atoms header has no '") + req + "' column ('" + header + "')");
  }
  std::size_t need = 0;
  for (int c : {c_id, c_mol, c_type, c_x, c_y, c_r, c_m, c_vx, c_vy, c_w})
    need = std::max(need, static_cast<std::size_t>(c + 1));
  frame.discs.reserve(static_cast<std::size_t>(h.count));
  // What each of the first `need` columns holds, for rows read in place.
  enum Role : std::uint8_t { kSkip, kId, kMol, kType, kX, kY, kR, kM, kVx, kVy, kW };
  std::vector<Role> roles(need, kSkip);
  const std::pair<int, Role> role_of[] = {{c_id, kId}, {c_mol, kMol}, {c_type, kType}, {c_x, kX},   {c_y, kY},
                                          {c_r, kR},   {c_m, kM},     {c_vx, kVx},     {c_vy, kVy}, {c_w, kW}};
  for (const auto& [c, role] : role_of)
    if (c >= 0) roles[static_cast<std::size_t>(c)] = role;
  const double density_pi = density_ * std::numbers::pi;
  // A well-formed row, parsed straight from the line; false sends it to the checks below.
  auto fast_row = [&](std::string_view row, Disc& d) {
    const char* p = row.data();
    const char* const end = p + row.size();
    std::int64_t type = d.type;
    std::int64_t* const ints[] = {nullptr, &d.id, &d.mol, &type};
    double* const doubles[] = {&d.x, &d.y, &d.radius, &d.mass, &d.vx, &d.vy, &d.omega};  // kX ... kW
    bool mass_given = false;
    for (const Role role : roles) {
      bool ok;
      if (role >= kX) {
        ok = detail::NextDouble(p, end, *doubles[role - kX]);
        mass_given |= role == kM;
      } else if (role != kSkip) {
        ok = detail::NextInt(p, end, *ints[role]);
      } else {
        ok = !detail::NextField(p, end).empty();
      }
      if (!ok) return false;
    }
    d.type = static_cast<int>(type);
    if (!mass_given) d.mass = density_pi * d.radius * d.radius;
    return true;
  };
  std::string_view line;
  std::vector<std::string_view> f;
  auto field = [&](int c) { return f[static_cast<std::size_t>(c)]; };
  for (std::int64_t a = 0; a < h.count; ++a) {
    if (!in.Next(line)) {
      frame.discs.clear();
      return false;  // truncated at the end of the file
    }
    if (Disc& d = frame.discs.emplace_back(); fast_row(line, d)) continue;
    frame.discs.pop_back();
    Split(line, ' ', f);
    if (f.size() < need && in.AtEnd()) {
      frame.discs.clear();
      return false;  // last line cut short: an engine still writing
    }
    if (f.size() < need)
      in.Fail("atom row has " + std::to_string(f.size()) + " fields, the header names " + std::to_string(names.size()));
    Disc d;
    std::int64_t iv = 0;
    auto num = [&](int c, double& out, const char* what) {
      if (c < 0) return;
      if (!ToDouble(field(c), out)) in.Fail(std::string(what) + " '" + std::string(field(c)) + "' is not a number");
    };
    if (!ToInt(field(c_id), d.id)) in.Fail("id '" + std::string(field(c_id)) + "' is not an integer");
    if (!ToInt(field(c_mol), d.mol)) in.Fail("mol '" + std::string(field(c_mol)) + "' is not an integer");
    if (c_type >= 0) {
      if (!ToInt(field(c_type), iv)) in.Fail("type '" + std::string(field(c_type)) + "' is not an integer");
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

}  // namespace granary::rundir
