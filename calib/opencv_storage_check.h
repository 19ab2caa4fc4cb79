// The YAML and XML that camera files hold, checked before OpenCV's FileStorage parser sees it.
//
// OpenCV 4.6's YAML parser is not safe on text it was not written for: fuzz_opencv_yaml found
// an empty key that makes it build a string of negative length and end the process in
// std::terminate (":x: 3", "{a: 1, : 3}"), and a stray document marker on which it loops
// forever ("%YAML:1.0\n---%YAML:1.0\n--\n-"). Refusing the inputs found one at a time
// would leave the next one for the user to find, so the check is a whitelist instead: the
// block-and-flow subset of YAML that OpenCV writes and that people write by hand in camera
// files, with a one-line error naming the line of anything else.
//
// Accepted, line by line:
//   %YAML:1.0 (or "%YAML 1.0") as the first line; "---" alone directly after it;
//   blank lines and comments ("# ..." alone, or after a value);
//   key: value | key: | key: !!tag | key: !!tag value   keys [A-Za-z_][A-Za-z0-9_.-]*
//   - value                                            sequence items
//   values: plain scalars (no ": ", no leading indicator), "quoted" or 'quoted' strings on
//   one line, flow collections [ ... ] / { key: value, ... } that may span lines indented
//   deeper than their key, nested at most 8 deep;
//   indentation with spaces, deeper only under a "key:" that opened a block, back only to
//   a level used before, at most 16 levels.
// Refused: tabs and other control characters outside comments, any other directive or
// document marker, empty keys or items, unbalanced brackets, anything after a closed
// collection but a comment.
#pragma once

#include <string>

namespace lp {

// InputError "<path>: line N: <what>" if `text` is outside the subset above.
void check_opencv_yaml_text(const std::string& path, const std::string& text);

// OpenCV's XML parser dereferences a null pointer on a NUL byte inside the header
// (fuzz_opencv_xml), so XML is held to the subset OpenCV writes in the same way:
//   <?xml version="1.0"?> (attributes name="value" only), then <opencv_storage> ... its
//   close, with only blanks and <!-- comments --> around;
//   elements <name> or <name type_id="..."> holding either text or elements (blanks
//   aside), names [A-Za-z_][A-Za-z0-9_.-]*, closed by </name>, at most 16 deep;
//   text without '<', entities only &lt; &gt; &amp; &quot; &apos;.
// Both formats refuse control bytes (NUL and below 0x20 but tab, CR and LF) anywhere.
void check_opencv_xml_text(const std::string& path, const std::string& text);

}  // namespace lp
