// SPDX-License-Identifier: Apache-2.0
// What `rtm` prints of text that components and the naming service give it: never a control
// sequence a terminal would act on.
#include "report.h"

#include <gtest/gtest.h>

namespace {

using rtm::cli::shown_name;
using rtm::cli::terminal_text;

TEST(TerminalText, PrintableTextAndUtf8AreShownAsTheyAre) {
  EXPECT_EQ(terminal_text("sensor0.wrench fx [N·m] µs Ωé漢字 🙂"), "sensor0.wrench fx [N·m] µs Ωé漢字 🙂");
}

TEST(TerminalText, ControlCharactersAndTheBackslashAreEscaped) {
  EXPECT_EQ(terminal_text("a\x1b[2Jb"), "a\\x1b[2Jb");
  EXPECT_EQ(terminal_text("one\ntwo\rthree\tfour\x07\x7f"), "one\\ntwo\\x0dthree\\tfour\\x07\\x7f");
  EXPECT_EQ(terminal_text("C:\\x"), "C:\\\\x");
}

TEST(TerminalText, C1ControlsAndLineSeparatorsInUtf8AreEscapedByteByByte) {
  EXPECT_EQ(terminal_text("\xc2\x9b" "31m"), "\\xc2\\x9b31m");      // U+009B, a terminal's CSI
  EXPECT_EQ(terminal_text("a\xe2\x80\xa8z"), "a\\xe2\\x80\\xa8z");  // U+2028
}

TEST(TerminalText, BytesThatAreNoUtf8AreEscaped) {
  EXPECT_EQ(terminal_text("\xff"), "\\xff");
  EXPECT_EQ(terminal_text("\xc0\xaf"), "\\xc0\\xaf");              // an overlong '/'
  EXPECT_EQ(terminal_text("\xed\xa0\x80"), "\\xed\\xa0\\x80");      // a surrogate
  EXPECT_EQ(terminal_text("\xe2\x82"), "\\xe2\\x82");              // cut short
  EXPECT_EQ(terminal_text("\xf4\x90\x80\x80"), "\\xf4\\x90\\x80\\x80");  // above U+10FFFF
}

TEST(ShownName, ANameThatBreaksTheNamingRuleIsEscapedAndMarked) {
  EXPECT_EQ(shown_name("sensor0"), "sensor0");
  EXPECT_EQ(shown_name("<img src=x onerror=alert(1)>"), "<img src=x onerror=alert(1)> (not a valid name)");
  EXPECT_EQ(shown_name("a\x1b]0;x\x07"), "a\\x1b]0;x\\x07 (not a valid name)");
  EXPECT_EQ(shown_name(""), " (not a valid name)");
}

}  // namespace
