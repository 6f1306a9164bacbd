#include "isoloft/io/label_names.h"

#include <sys/stat.h>

#include <filesystem>

#include "isoloft/core/error.h"
#include "isoloft/core/sanitize.h"
#include "isoloft/io/file_util.h"
#include "isoloft/io/text.h"

namespace fs = std::filesystem;

namespace isoloft {

std::string LabelNames::name(std::uint32_t label) const {
  const auto it = names.find(label);
  return it == names.end() ? std::string() : it->second;
}

LabelNames read_label_names(const std::string& path) {
  detail::check_regular_file(path);
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && std::uint64_t(st.st_size) > kMaxLabelTableBytes)
    throw InputError(path, "a label table of " + std::to_string(st.st_size) + " bytes (at most " +
                               std::to_string(kMaxLabelTableBytes) + "): not a label table");
  const std::vector<unsigned char> bytes = detail::read_file_bytes(path);
  LabelNames out;
  out.file = path;
  std::map<std::uint32_t, std::size_t> line_of;
  detail::Lines lines(bytes.data(), bytes.data() + bytes.size());
  std::string_view line;
  std::vector<std::string_view> tok;
  while (lines.next(line)) {
    const std::size_t n = lines.number();
    auto fail = [&](const std::string& what) { return InputError(path, "line " + std::to_string(n) + ": " + what); };
    const std::string_view t = detail::trim(line);
    if (t.empty() || t.front() == '#') continue;
    if (t.find('\0') != std::string_view::npos) throw fail("a NUL byte");
    if (!is_utf8(t)) throw fail("not UTF-8 text ('" + terminal_text(t) + "')");
    detail::split_tokens(t, tok, false);
    long long label = -1;
    if (!detail::parse_number(tok.front(), label) || label < 0 || label > 0xFFFFFFFFLL)
      throw fail("expected a label number (0 .. 2^32 - 1) first, got '" + terminal_text(tok.front()) + "'");
    std::string name;
    if (const auto q = t.find('"'); q != std::string_view::npos) {  // ITK-SNAP: the quoted description
      const auto e = t.find('"', q + 1);
      if (e == std::string_view::npos) throw fail("a quote is not closed");
      name = std::string(t.substr(q + 1, e - q - 1));
    } else {
      if (tok.size() < 2) throw fail("label " + std::to_string(label) + " has no name");
      name = std::string(tok[1]);
    }
    if (label == 0) continue;  // the background
    const auto l = std::uint32_t(label);
    if (const auto it = out.names.find(l); it != out.names.end()) {
      if (it->second == name) continue;
      throw fail("label " + std::to_string(l) + " is named '" + terminal_text(name) + "' here and '" +
                 terminal_text(it->second) + "' on line " + std::to_string(line_of[l]));
    }
    out.names.emplace(l, std::move(name));
    line_of[l] = n;
  }
  if (out.names.empty()) throw InputError(path, "no label is named (lines of: a label number, then its name)");
  return out;
}

std::optional<std::string> label_names_beside(const std::string& volume) {
  fs::path p(volume);
  if (p.extension() == ".gz") p.replace_extension();  // aal.nii.gz -> aal.nii
  fs::path stem = p;
  stem.replace_extension();  // aal.nii -> aal
  for (const fs::path& c : {fs::path(p.string() + ".txt"), fs::path(stem.string() + ".txt"),
                            fs::path(stem.string() + ".ctbl"), fs::path(stem.string() + "_labels.txt"),
                            fs::path(stem.string() + ".label")}) {
    std::error_code ec;
    if (c != fs::path(volume) && fs::is_regular_file(c, ec)) return c.string();
  }
  return std::nullopt;
}

}  // namespace isoloft
