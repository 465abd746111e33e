// A small well-formedness check for the SVG and HTML the program writes: every element closed in
// order, every '&' an entity, attribute values quoted. Not a full XML parser; enough to catch a
// missing close tag or an unescaped label.
#pragma once

#include <string>
#include <vector>

namespace desslam::test {

// Empty when well formed; otherwise what is wrong and where. `void_elements` are HTML elements
// without a close tag (meta, br, img).
inline std::string xmlProblem(const std::string& text, const std::vector<std::string>& void_elements = {}) {
  std::vector<std::string> open;
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '&') {
      const size_t semi = text.find(';', i);
      if (semi == std::string::npos || semi - i > 8) return "unescaped '&' at " + std::to_string(i);
      continue;
    }
    if (text[i] != '<') continue;
    if (text.compare(i, 4, "<!--") == 0) {
      i = text.find("-->", i);
      if (i == std::string::npos) return "unclosed comment";
      continue;
    }
    if (text.compare(i, 2, "<!") == 0 || text.compare(i, 2, "<?") == 0) {
      i = text.find('>', i);
      continue;
    }
    // Inside a tag: find its end outside quoted attribute values.
    size_t end = i + 1;
    char quote = 0;
    for (; end < text.size(); ++end) {
      if (quote != 0) {
        if (text[end] == quote) quote = 0;
        else if (text[end] == '<') return "'<' inside an attribute value at " + std::to_string(end);
      } else if (text[end] == '"' || text[end] == '\'') {
        quote = text[end];
      } else if (text[end] == '>') {
        break;
      }
    }
    if (end >= text.size()) return "unterminated tag at " + std::to_string(i);
    const bool closing = text[i + 1] == '/';
    const bool self_closing = text[end - 1] == '/';
    size_t name_start = i + (closing ? 2 : 1), name_end = name_start;
    while (name_end < end && text[name_end] != ' ' && text[name_end] != '/' && text[name_end] != '\n') ++name_end;
    const std::string name = text.substr(name_start, name_end - name_start);
    if (name.empty()) return "empty tag name at " + std::to_string(i);
    bool is_void = false;
    for (const std::string& v : void_elements) is_void |= v == name;
    if (closing) {
      if (open.empty() || open.back() != name)
        return "</" + name + "> at " + std::to_string(i) + " closes " + (open.empty() ? "nothing" : "<" + open.back() + ">");
      open.pop_back();
    } else if (!self_closing && !is_void) {
      open.push_back(name);
      // <style> and <script> hold text, not markup.
      if (name == "style" || name == "script") {
        const size_t close = text.find("</" + name + ">", end);
        if (close == std::string::npos) return "unclosed <" + name + ">";
        end = close - 1;
      }
    }
    i = end;
  }
  if (!open.empty()) return "<" + open.back() + "> is never closed";
  return {};
}

}  // namespace desslam::test
