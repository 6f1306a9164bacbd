// Names made safe for a terminal and for a spreadsheet's CSV cell
// (core/sanitize.h): the attacks (ESC/BEL sequences, a bare CR,
// formula cells) and what must pass through unchanged.
#include <gtest/gtest.h>

#include <rapidcheck/gtest.h>

#include <string>

#include "isoloft/core/sanitize.h"

using namespace isoloft;

TEST(Sanitize, TerminalTextEscapesControlBytesAndKeepsPrintableUtf8) {
  EXPECT_EQ(terminal_text("Heart"), "Heart");
  EXPECT_EQ(terminal_text("R\xC3\xBC" "ckenmark"), "R\xC3\xBC" "ckenmark") << "Latin letters decoded to UTF-8 stay";
  EXPECT_EQ(terminal_text("\xE8\x84\x8A\xE9\xAB\x84"), "\xE8\x84\x8A\xE9\xAB\x84") << "kana/kanji stay";
  EXPECT_EQ(terminal_text("\x1b]0;owned\x07"), "\\x1B]0;owned\\x07") << "OSC title sequence";
  EXPECT_EQ(terminal_text("\x1b[2J"), "\\x1B[2J") << "clear screen";
  EXPECT_EQ(terminal_text("ok\rHeart"), "ok\\x0DHeart") << "bare CR";
  EXPECT_EQ(terminal_text("a\nb\tc\x7f"), "a\\x0Ab\\x09c\\x7F");
  EXPECT_EQ(terminal_text(std::string("A\0B", 3)), "A\\x00B");
  EXPECT_EQ(terminal_text("\xC2\x9B" "31m"), "\\u{009B}31m") << "C1 CSI";
  EXPECT_EQ(terminal_text("abc\xE2\x80\xAE" "fdp.exe"), "abc\\u{202E}fdp.exe") << "right-to-left override";
  EXPECT_EQ(terminal_text("caf\xE9"), "caf\\xE9") << "Latin-1 byte, not UTF-8";
  EXPECT_EQ(terminal_text("\xC0\xAF"), "\\xC0\\xAF") << "overlong";
  EXPECT_EQ(terminal_text("\xED\xA0\x80"), "\\xED\\xA0\\x80") << "surrogate";
  EXPECT_EQ(terminal_text("\xE2\x82"), "\\xE2\\x82") << "cut short";
}

RC_GTEST_PROP(Sanitize, TerminalTextHasNoControlByteAndIsUtf8, (const std::string& s)) {
  const std::string t = terminal_text(s);
  RC_ASSERT(is_utf8(t));
  for (std::size_t i = 0; i < t.size(); ++i) {
    const auto c = static_cast<unsigned char>(t[i]);
    RC_ASSERT(c >= 0x20);
    RC_ASSERT(c != 0x7F);
    if (c == 0xC2 && i + 1 < t.size()) RC_ASSERT(static_cast<unsigned char>(t[i + 1]) >= 0xA0);
  }
}

TEST(Sanitize, CsvCellNeutralisesFormulaTriggersAndQuotes) {
  EXPECT_EQ(csv_cell("Heart"), "Heart");
  EXPECT_EQ(csv_cell("Lt Lung"), "Lt Lung");
  EXPECT_EQ(csv_cell(""), "");
  EXPECT_EQ(csv_cell("=1+2"), "\"'=1+2\"");
  EXPECT_EQ(csv_cell("+1"), "\"'+1\"");
  EXPECT_EQ(csv_cell("-2+3"), "\"'-2+3\"");
  EXPECT_EQ(csv_cell("@SUM(A1)"), "\"'@SUM(A1)\"");
  EXPECT_EQ(csv_cell("\t=1"), "\"'\t=1\"");
  EXPECT_EQ(csv_cell("\r=1"), "\"'\r=1\"");
  EXPECT_EQ(csv_cell("=HYPERLINK(\"http://x\",\"y\")"), "\"'=HYPERLINK(\"\"http://x\"\",\"\"y\"\")\"");
  EXPECT_EQ(csv_cell("a,b"), "\"a,b\"");
  EXPECT_EQ(csv_cell("say \"hi\""), "\"say \"\"hi\"\"\"");
  EXPECT_EQ(csv_cell("two\nlines"), "\"two\nlines\"");
  EXPECT_EQ(csv_cell("a=b"), "a=b") << "only a leading trigger";
}

// Read back by RFC 4180 rules, a cell is the name (with the quote if it was
// neutralised), and it never starts with a trigger.
RC_GTEST_PROP(Sanitize, CsvCellReadsBackAndNeverStartsAFormula, (const std::string& s)) {
  const std::string c = csv_cell(s);
  std::string back;
  if (!c.empty() && c.front() == '"') {
    RC_ASSERT(c.size() >= 2);
    RC_ASSERT(c.back() == '"');
    for (std::size_t i = 1; i + 1 < c.size(); ++i) {
      back += c[i];
      if (c[i] == '"') {
        RC_ASSERT(c[i + 1] == '"');
        ++i;
      }
    }
  } else {
    RC_ASSERT(c.find_first_of(",\"\r\n") == std::string::npos);
    back = c;
  }
  const bool trigger = !s.empty() && std::string("=+-@\t\r").find(s.front()) != std::string::npos;
  RC_ASSERT(back == (trigger ? "'" + s : s));
}
