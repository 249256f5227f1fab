// Text shared by the run-directory writers and readers (not part of the API): the LAMMPS dump
// header lines, fields split without copies, numbers by std::from_chars (no locale, no
// allocation).
#pragma once

#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace granary::rundir::detail {

// Fields of `s`: separated by runs of blanks when `sep` is ' ', else by `sep` with the
// blanks around each field trimmed.
inline void Split(std::string_view s, char sep, std::vector<std::string_view>& out) {
  out.clear();
  if (sep == ' ') {
    // The hot loop of every dump reader: one comparison per character (blank = ' ', '\t',
    // '\r' or any other control character).
    const char* p = s.data();
    const char* const end = p + s.size();
    for (;;) {
      while (p < end && static_cast<unsigned char>(*p) <= ' ') ++p;
      if (p == end) return;
      const char* start = p;
      while (p<end&& static_cast<unsigned char>(*p)> ' ') ++p;
      out.emplace_back(start, static_cast<std::size_t>(p - start));
    }
  }
  std::size_t start = 0;
  for (;;) {
    const std::size_t end = s.find(sep, start);
    std::string_view field = s.substr(start, end == std::string_view::npos ? std::string_view::npos : end - start);
    while (!field.empty() && (field.back() == '\r' || field.back() == ' ')) field.remove_suffix(1);
    while (!field.empty() && field.front() == ' ') field.remove_prefix(1);
    out.push_back(field);
    if (end == std::string_view::npos) break;
    start = end + 1;
  }
}

// Appends the run of decimal digits at `p` to m (m = 10 m + digit, modulo 2^64) and leaves
// `p` after it. Eight bytes at a time where eight are left before `end` (SWAR: the digits of
// one 64-bit load found by a mask and combined by three multiplies, as in fast_float), which
// gives the same m as one digit at a time.
inline void AppendDigits(const char*& p, const char* const end, std::uint64_t& m) {
  static constexpr std::uint64_t kPow10Int[9] = {1, 10, 100, 1000, 10000, 100000, 1000000, 10000000, 100000000};
  if constexpr (std::endian::native == std::endian::little) {
    while (end - p >= 8) {
      std::uint64_t word;
      std::memcpy(&word, p, 8);
      const std::uint64_t x = word ^ 0x3030303030303030;  // a digit's byte is now its value 0..9
      // A byte's high nibble is set here iff it is not a digit (bytes after the first non-digit
      // may be marked wrongly by a carry; only the first matters).
      const std::uint64_t not_digit = (x | (x + 0x0606060606060606)) & 0xF0F0F0F0F0F0F0F0;
      const int n = not_digit ? std::countr_zero(not_digit) >> 3 : 8;
      if (n == 0) return;
      // The n digits as the last n of eight (leading zeros), then two bytes, four, eight at once.
      std::uint64_t v = x << (8 * (8 - n));
      v = v * 10 + (v >> 8);
      v = (((v & 0x000000FF000000FF) * (100 + (1000000ULL << 32))) +
           (((v >> 16) & 0x000000FF000000FF) * (1 + (10000ULL << 32)))) >>
          32;
      m = m * kPow10Int[n] + v;
      p += n;
      if (n < 8) return;
    }
  }
  while (p != end && static_cast<unsigned>(*p - '0') < 10u) m = m * 10 + static_cast<unsigned>(*p++ - '0');
}

// Clinger's fast path: a decimal of at most 19 digits whose digits m (as an integer) are at
// most 2^53 and whose exponent e has |e| <= 22 is m * 10^e or m / 10^-e, one correctly rounded
// IEEE operation on two exact doubles, so it has the bits std::from_chars gives. The dumps'
// "%.10g" numbers all take it (twice as fast as from_chars). Reads the number at `p` (no '+')
// and leaves `p` after it; false when the fast path does not apply (the caller then asks
// from_chars, and `p` is wherever the scan stopped).
inline bool FastDecimal(const char*& p, const char* const end, double& v) {
  static constexpr double kPow10[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                        1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
  const bool negative = p != end && *p == '-';
  if (negative) ++p;
  auto digit = [](char c) { return static_cast<unsigned>(c - '0') < 10u; };
  std::uint64_t m = 0;  // wraps past 19 digits, which then take the slow path
  const char* const int_start = p;
  AppendDigits(p, end, m);
  int digits = static_cast<int>(p - int_start);
  int exponent = 0;
  if (p != end && *p == '.') {
    const char* const frac_start = ++p;
    AppendDigits(p, end, m);
    exponent = -static_cast<int>(p - frac_start);
    digits -= exponent;
  }
  bool fast = digits > 0 && digits <= 19;
  if (fast && p != end && (*p == 'e' || *p == 'E')) {
    ++p;
    const bool exp_negative = p != end && *p == '-';
    if (p != end && (*p == '-' || *p == '+')) ++p;
    const char* const exp_start = p;
    int e = 0;
    while (p != end && digit(*p) && p - exp_start < 4) e = e * 10 + (*p++ - '0');
    fast = p != exp_start;
    exponent += exp_negative ? -e : e;
  }
  if (!fast || m > (std::uint64_t{1} << 53) || exponent < -22 || exponent > 22) return false;
  double d = static_cast<double>(m);
  d = exponent < 0 ? d / kPow10[-exponent] : d * kPow10[exponent];
  v = negative ? -d : d;
  return true;
}

// `s` as a double with std::from_chars' bits (a leading '+' allowed); false if it is not one.
inline bool ToDouble(std::string_view s, double& v) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const char* p = s.data();
  const char* const end = p + s.size();
  if (FastDecimal(p, end, v) && p == end) return true;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  return ec == std::errc() && ptr == s.data() + s.size();
}

inline bool ToInt(std::string_view s, std::int64_t& v) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec == std::errc() && ptr == s.data() + s.size()) return true;
  // Some writers print integers as "12.0".
  double d = 0.0;
  if (ToDouble(s, d) && std::floor(d) == d && std::abs(d) < 9e15) {
    v = static_cast<std::int64_t>(d);
    return true;
  }
  return false;
}

// Rows read in place: the next blank-separated field of [p, end) (see Split) parsed straight
// from the line, with no field vector and no second pass over the characters. Each leaves `p`
// after the field and returns false if there is no field or it is not a number; the caller
// then re-reads the row the slow way (Split, ToDouble) for its error message.
inline bool SkipBlanks(const char*& p, const char* end) {
  while (p < end && static_cast<unsigned char>(*p) <= ' ') ++p;
  return p != end;
}
inline std::string_view NextField(const char*& p, const char* end) {
  if (!SkipBlanks(p, end)) return {};
  const char* const start = p;
  while (p<end&& static_cast<unsigned char>(*p)> ' ') ++p;
  return {start, static_cast<std::size_t>(p - start)};
}
inline bool NextDouble(const char*& p, const char* end, double& v) {
  if (!SkipBlanks(p, end)) return false;
  const char* q = p;  // a local cursor: no store through p per digit
  if (FastDecimal(q, end, v) && (q == end || static_cast<unsigned char>(*q) <= ' ')) {
    p = q;
    return true;
  }
  return ToDouble(NextField(p, end), v);
}
inline bool NextInt(const char*& p, const char* end, std::int64_t& v) {
  if (!SkipBlanks(p, end)) return false;
  const char* const start = p;
  const bool negative = *p == '-';
  if (negative) ++p;
  std::int64_t m = 0;
  const char* const digits = p;
  while (p != end && static_cast<unsigned>(*p - '0') < 10u && p - digits < 18) m = m * 10 + (*p++ - '0');
  if (p != digits && (p == end || static_cast<unsigned char>(*p) <= ' ')) {
    v = negative ? -m : m;
    return true;
  }
  p = start;
  return ToInt(NextField(p, end), v);
}

// Index of `name` in `names`, or -1.
inline int Column(const std::vector<std::string>& names, const std::string& name) {
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return static_cast<int>(i);
  return -1;
}

// The header of one dump block up to (not including) its column line, as LAMMPS writes it
// (dump custom / dump local with `dump_modify time yes`): TIME, TIMESTEP, the count under
// `count_item` ("NUMBER OF ATOMS" or "NUMBER OF ENTRIES"), BOX BOUNDS. LAMMPS' read_dump
// expects this order (reader_native.cpp skips UNITS and TIME, then requires TIMESTEP).
inline void WriteDumpHeader(std::FILE* out, std::int64_t timestep, double time, const char* count_item,
                            std::size_t count, const double (&box)[3][2]) {
  std::fprintf(out, "ITEM: TIME\n%.16g\nITEM: TIMESTEP\n%lld\nITEM: %s\n%zu\n", time, static_cast<long long>(timestep),
               count_item, count);
  std::fprintf(out, "ITEM: BOX BOUNDS ff ff pp\n%.16g %.16g\n%.16g %.16g\n%.16g %.16g\n", box[0][0], box[0][1],
               box[1][0], box[1][1], box[2][0], box[2][1]);
}

// Dump rows built in memory: numbers by std::to_chars, which the standard defines as printf
// in the "C" locale with the same precision, so AppendG10 writes the characters of "%.10g",
// at a fraction of the cost (no format parsing, no locale, no FILE lock per row).
inline void AppendInt(std::string& out, std::int64_t v) {
  char buf[24];
  out.append(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
}
inline void AppendG10(std::string& out, double v) {
  char buf[40];
  out.append(buf, std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, 10).ptr);
}
// 17 significant digits: a double read back exactly.
inline void AppendG17(std::string& out, double v) {
  char buf[40];
  out.append(buf, std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, 17).ptr);
}
// Writes `text` and clears it (keeping its capacity).
inline void Drain(std::string& text, std::FILE* out) {
  std::fwrite(text.data(), 1, text.size(), out);
  text.clear();
}
// Rows are written in blocks of this many (a few hundred kB of text).
inline constexpr std::size_t kRowsPerWrite = 4096;

inline std::string Where(const std::filesystem::path& file, std::int64_t line) {
  return file.string() + ":" + std::to_string(line);
}

// The lines of a dump, plain or gzip-compressed, with their numbers, for errors that name
// file:line. The file is read in large blocks and a line is a view into the block (no copy,
// no allocation per line).
class DumpLines {
 public:
  explicit DumpLines(const std::filesystem::path& file);
  // The next line without its '\n' and '\r'; false at the end of the file. The view is valid
  // until the next call.
  bool Next(std::string_view& line);
  bool Next(std::string& line);  // the same, copied
  // Throws ReadError "file:line: what".
  [[noreturn]] void Fail(const std::string& what) const;
  // The last line read ended at the end of the file without its '\n' (a writer may be in it).
  bool AtEnd() const { return unterminated_; }
  ~DumpLines();
  DumpLines(const DumpLines&) = delete;
  DumpLines& operator=(const DumpLines&) = delete;

 private:
  // Moves the unread tail to the front and reads after it; false if nothing more came.
  bool Refill();
  std::filesystem::path file_;
  std::FILE* plain_ = nullptr;
  void* gz_ = nullptr;  // gzFile (told by the magic bytes); zlib's pass-through read plain files 15 % slower
  std::vector<char> buffer_;
  std::size_t begin_ = 0, end_ = 0;  // the unread bytes of buffer_
  bool eof_ = false, unterminated_ = false;
  std::int64_t line_no_ = 0;
};

// The header of one dump block. `columns` are the names after "ITEM: ATOMS" / "ITEM: ENTRIES".
struct DumpHeader {
  std::int64_t timestep = 0;
  double time = 0.0;
  std::int64_t count = -1;
  double box[3][2] = {{0, 0}, {0, 0}, {-0.5, 0.5}};
  std::vector<std::string> columns;
};

// Reads the header of the next block up to and including its column line `columns_item`
// ("ITEM: ATOMS" or "ITEM: ENTRIES"), with the count under "ITEM: " + count_item; unknown
// items (one value line) are skipped. False at the end of the file, or when the header is
// cut short there (an engine still writing); a malformed header throws ReadError.
bool ReadDumpHeader(DumpLines& in, const char* count_item, const char* columns_item, DumpHeader& header);

// A dump reader's state: its lines and the header of the block whose rows come next.
struct DumpState {
  explicit DumpState(const std::filesystem::path& file) : lines(file) {}
  DumpLines lines;
  DumpHeader header;
  bool rows_pending = false;
};

// Skips the rows of the block whose header was read; false if the file ends first.
bool SkipDumpRows(DumpState& state);

}  // namespace granary::rundir::detail
