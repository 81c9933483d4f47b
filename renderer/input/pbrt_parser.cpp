// pbrt-v4 scene reader: tokenizer, parameter lists, graphics state and directives.
//
// Structure follows the pbrt-v4 file format reference: a stream of directives, each with a fixed
// list of arguments followed, for entity directives, by a parameter list of `"type name" value`
// pairs. The graphics state (CTM, material, area light, orientation, attribute defaults) is a
// stack pushed by AttributeBegin / TransformBegin / ObjectBegin. Conventions: pbrt_parser.h.
#include "renderer/input/pbrt_parser.h"

#include <algorithm>
#include <charconv>
#include <cfloat>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string_view>

#include "renderer/util/gzip_io.h"
#include "renderer/util/limits.h"
#include "renderer/util/spectra.h"

namespace tessera {

namespace {

namespace fs = std::filesystem;

/// One lexical token. `quoted` tokens are strings with escapes already resolved.
struct Token {
    std::string text;
    bool quoted = false;
    int line = 0;
    bool is(const char *s) const { return !quoted && text == s; }
};

/// Splits pbrt text into tokens: "quoted strings", [ and ], and bare words (directive names,
/// numbers, true/false). '#' starts a comment up to the end of the line.
class Tokenizer {
  public:
    Tokenizer(std::string text, std::string file)
        : text_(std::move(text)), file_(std::move(file)) {
        // A UTF-8 byte order mark (some editors write one) is not part of the scene.
        if (text_.starts_with("\xEF\xBB\xBF")) pos_ = 3;
    }

    const std::string &file() const { return file_; }
    FileLoc loc(int line) const { return {file_, line}; }
    FileLoc loc(const Token &t) const { return {file_, t.line}; }

    /// Next token, or std::nullopt at the end of the text.
    std::optional<Token> next() {
        std::optional<Token> t;
        if (peeked_) {
            t = std::move(peeked_);
            peeked_.reset();
        } else {
            t = lex();
        }
        if (t) last_line_ = t->line;
        return t;
    }
    const Token *peek() {
        if (!peeked_) peeked_ = lex();
        return peeked_ ? &*peeked_ : nullptr;
    }
    /// Line of the last token returned by next() (for "unexpected end of file" messages).
    int line() const { return last_line_; }

  private:
    std::optional<Token> lex() {
        while (pos_ < text_.size()) {
            char c = text_[pos_];
            if (c == '\n') {
                ++line_;
                ++pos_;
            } else if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') {
                ++pos_;
            } else if (c == '#') {
                while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
            } else if (c == '[' || c == ']') {
                ++pos_;
                return Token{std::string(1, c), false, line_};
            } else if (c == '"') {
                return lex_string();
            } else {
                size_t start = pos_;
                while (pos_ < text_.size()) {
                    char d = text_[pos_];
                    if (d == ' ' || d == '\n' || d == '\t' || d == '\r' || d == '\f' ||
                        d == '\v' || d == '"' || d == '[' || d == ']' || d == '#')
                        break;
                    // Directives, numbers and true/false are ASCII: anything else outside a
                    // string means a binary, UTF-16 or otherwise damaged file. Say so rather
                    // than echo raw bytes in an "unknown directive" message.
                    if (!is_word_byte(d)) throw bad_byte(d);
                    ++pos_;
                }
                return Token{text_.substr(start, pos_ - start), false, line_};
            }
        }
        return std::nullopt;
    }

    static bool is_word_byte(char c) { return c > ' ' && c < 0x7f; }

    SceneError bad_byte(char c) const {
        char hex[8];
        std::snprintf(hex, sizeof hex, "0x%02x", unsigned(static_cast<unsigned char>(c)));
        return SceneError(loc(line_), std::string("unexpected byte ") + hex +
                                          " (not a text file? pbrt scenes are ASCII or UTF-8 "
                                          "text)");
    }

    Token lex_string() {
        int start_line = line_;
        ++pos_;  // opening quote
        std::string s;
        while (true) {
            if (pos_ >= text_.size())
                throw SceneError(loc(start_line), "unterminated string");
            char c = text_[pos_++];
            if (c == '"') break;
            if (c == '\n')
                throw SceneError(loc(start_line), "unterminated string");
            // Control characters (a NUL would cut a file name short) are never valid; UTF-8
            // bytes are.
            if (static_cast<unsigned char>(c) < 0x20 && c != '\t') throw bad_byte(c);
            if (c == '\\') {
                if (pos_ >= text_.size())
                    throw SceneError(loc(start_line), "unterminated string");
                char e = text_[pos_++];
                switch (e) {
                case 'b': s += '\b'; break;
                case 'f': s += '\f'; break;
                case 'n': s += '\n'; break;
                case 'r': s += '\r'; break;
                case 't': s += '\t'; break;
                case '\\': s += '\\'; break;
                case '\'': s += '\''; break;
                case '"': s += '"'; break;
                default:
                    throw SceneError(loc(line_), std::string("unexpected escaped character '") +
                                                     e + "' in string");
                }
                continue;
            }
            s += c;
        }
        return Token{std::move(s), true, start_line};
    }

    std::string text_, file_;
    size_t pos_ = 0;
    int line_ = 1, last_line_ = 1;
    std::optional<Token> peeked_;
};

/// Parses a whole bare token as a number; std::nullopt if it is not one.
std::optional<double> to_number(const Token &t) {
    if (t.quoted || t.text.empty()) return std::nullopt;
    const char *b = t.text.data();
    const char *e = b + t.text.size();
    if (*b == '+') ++b;  // from_chars rejects a leading '+'
    double v = 0;
    auto [ptr, ec] = std::from_chars(b, e, v);
    // Every number ends up in a float: reject what a float cannot hold (NaN, Inf, 1e39).
    if (ec != std::errc() || ptr != e || !std::isfinite(v) || std::abs(v) > double(FLT_MAX))
        return std::nullopt;
    return v;
}

/// The pbrt graphics state (pbrt-v4 BasicSceneBuilder::GraphicsState, minus the colour space).
struct GraphicsState {
    Transform ctm;
    std::string medium_inside, medium_outside;  ///< MediumInterface ("" = vacuum)
    FileLoc medium_loc;
    bool reverse_orientation = false;
    std::string material;
    std::string area_light_type;
    ParamSet area_light;
    FileLoc area_light_loc;
    ParamSet shape_attrs, light_attrs, material_attrs, medium_attrs, texture_attrs;
};

/// What pushed a graphics-state stack entry.
enum class PushKind { Attribute, Transform, Object };

struct StackEntry {
    GraphicsState state;
    PushKind kind;
    FileLoc loc;
};

const char *push_name(PushKind k) {
    switch (k) {
    case PushKind::Attribute: return "AttributeBegin";
    case PushKind::Transform: return "TransformBegin";
    case PushKind::Object: return "ObjectBegin";
    }
    return "";
}

std::string dir_of(const std::string &path) {
    fs::path p(path);
    return p.has_parent_path() ? p.parent_path().string() : std::string();
}

std::string join(const std::string &dir, const std::string &file) {
    if (dir.empty() || fs::path(file).is_absolute()) return file;
    return (fs::path(dir) / file).string();
}

/// Reads a whole text file. Returns "" on success, else why not ("not found", "is a directory",
/// ...). Only regular files are read: a FIFO or a device such as /dev/zero would never end.
std::string read_text_file(const std::string &path, std::string *out) {
    // A ".gz" file is decompressed first (pbrt-v4 ReadDecompressedFileContents), up to the
    // text-file limit and a quarter of the memory budget.
    if (has_gz_extension(path))
        return read_gzip_file(path, out,
                              std::min<uint64_t>(kMaxTextFileBytes, memory_budget_bytes() / 4));
    std::error_code ec;
    fs::file_status st = fs::status(path, ec);
    if (ec || !fs::exists(st)) return "not found";
    if (fs::is_directory(st)) return "is a directory, not a file";
    if (!fs::is_regular_file(st)) return "is not a regular file";
    uintmax_t size = fs::file_size(path, ec);
    if (!ec && size > kMaxTextFileBytes)
        return "is larger than the maximum of " + format_bytes(kMaxTextFileBytes);
    std::ifstream in(path, std::ios::binary);
    if (!in) return "cannot be opened";
    std::ostringstream ss;
    ss << in.rdbuf();
    if (in.bad()) return "cannot be read";
    *out = ss.str();
    return "";
}

/// A path's identity for include-cycle detection: its canonical form when it exists.
std::string canonical_or_same(const std::string &path) {
    std::error_code ec;
    fs::path c = fs::weakly_canonical(path, ec);
    return ec ? path : c.string();
}

/// Appends to `params` every parameter of `defaults` whose name `params` lacks (Attribute).
void merge_defaults(ParamSet &params, const ParamSet &defaults) {
    for (const Param &d : defaults.params)
        if (!params.find(d.name)) params.params.push_back(d);
}

class Parser {
  public:
    Parser(SceneDesc &scene, std::string main_dir)
        : scene_(scene), main_dir_(std::move(main_dir)) {}

    /// Files being parsed, outermost first (Include cycles): canonical path and name as given.
    struct IncludeEntry {
        std::string id, name;
    };
    std::vector<IncludeEntry> include_stack_;

    /// Parses one file's tokens; `dir` is that file's directory.
    void parse(Tokenizer &tok, const std::string &dir, int depth);
    /// Checks done once the main file is finished.
    void finish(const Tokenizer &main);

  private:
    // --- the directives, one handler per group (parse); each returns false for a directive
    // that is not its own.
    /// The transformation directives (Identity ... ActiveTransform) and ReverseOrientation.
    bool transform_directive(Tokenizer &tok, const Token &t, const FileLoc &loc);
    /// The graphics-state blocks (AttributeBegin/End, TransformBegin/End), Attribute, and
    /// WorldBegin/WorldEnd.
    bool block_directive(Tokenizer &tok, const Token &t, const FileLoc &loc,
                         const std::string &dir);
    /// The rendering options before WorldBegin: Camera, Film, Sampler, Integrator, PixelFilter,
    /// Accelerator, ColorSpace and Option.
    bool option_directive(Tokenizer &tok, const Token &t, const FileLoc &loc,
                          const std::string &dir);
    /// Include (textual) and Import (pbrt-v4; the world block only): parses the named file.
    void include_directive(Tokenizer &tok, const Token &t, const FileLoc &loc,
                           const std::string &dir, int depth);
    /// Materials and textures: MakeNamedMaterial, Material, NamedMaterial, Texture.
    bool material_directive(Tokenizer &tok, const Token &t, const FileLoc &loc,
                            const std::string &dir);
    /// The world's contents: LightSource, AreaLightSource, Shape and object instancing
    /// (ObjectBegin, ObjectEnd, ObjectInstance).
    bool world_directive(Tokenizer &tok, const Token &t, const FileLoc &loc,
                         const std::string &dir);
    /// Participating media: MakeNamedMedium and MediumInterface.
    bool medium_directive(Tokenizer &tok, const Token &t, const FileLoc &loc,
                          const std::string &dir);

    // --- token helpers
    Token expect_token(Tokenizer &tok, const char *what) {
        std::optional<Token> t = tok.next();
        if (!t)
            throw SceneError(tok.loc(tok.line()), std::string("unexpected end of file: ") + what);
        return *t;
    }
    std::string expect_string(Tokenizer &tok, const std::string &directive) {
        Token t = expect_token(tok, (directive + " expects a quoted string").c_str());
        if (!t.quoted)
            throw SceneError(tok.loc(t), directive + " expects a quoted string, found '" +
                                             t.text + "'");
        return t.text;
    }
    double expect_number(Tokenizer &tok, const std::string &directive) {
        Token t = expect_token(tok, (directive + " expects a number").c_str());
        std::optional<double> v = to_number(t);
        if (!v)
            throw SceneError(tok.loc(t), directive + " expects a number, found '" + t.text + "'");
        return *v;
    }
    /// `n` numbers, optionally enclosed in [ ] (Transform and ConcatTransform use brackets).
    std::vector<double> expect_numbers(Tokenizer &tok, const std::string &directive, int n) {
        std::vector<double> v;
        const Token *p = tok.peek();
        bool bracket = p && p->is("[");
        if (bracket) tok.next();
        for (int i = 0; i < n; ++i) {
            if (bracket) {
                const Token *q = tok.peek();
                if (q && q->is("]"))
                    throw SceneError(tok.loc(*q), directive + " expects " + std::to_string(n) +
                                                      " numbers, found " + std::to_string(i));
            }
            v.push_back(expect_number(tok, directive));
        }
        if (bracket) {
            Token t = expect_token(tok, "missing ']'");
            if (!t.is("]"))
                throw SceneError(tok.loc(t), directive + " expects " + std::to_string(n) +
                                                 " numbers followed by ']', found '" + t.text +
                                                 "'");
        }
        return v;
    }

    ParamSet parse_params(Tokenizer &tok, const std::string &dir);
    Param parse_param(Tokenizer &tok, const Token &decl, const std::string &dir);

    // --- state helpers
    void apply_transform(const Transform &t) {
        if (!active_start_) return;  // only the StartTime transform is kept
        state_.ctm = state_.ctm * t;
    }
    void set_transform(const Transform &t) {
        if (!active_start_) return;
        state_.ctm = t;
    }
    void require_world(Tokenizer &tok, const Token &t) {
        if (!in_world_)
            throw SceneError(tok.loc(t), t.text + " is only allowed after WorldBegin");
    }
    void require_options(Tokenizer &tok, const Token &t) {
        if (in_world_)
            throw SceneError(tok.loc(t), t.text + " is not allowed after WorldBegin");
    }
    void push(PushKind kind, const FileLoc &loc) {
        if (stack_.size() >= size_t(kMaxAttributeNesting))
            throw SceneError(loc, std::string(push_name(kind)) + " nested more than " +
                                      std::to_string(kMaxAttributeNesting) + " deep");
        stack_.push_back({state_, kind, loc});
    }
    void pop(Tokenizer &tok, const Token &t, PushKind kind);
    /// Reads `name` as pbrt-v4 resolves it: against the main file's directory (its search
    /// directory), then the including file's directory `dir` as a fallback. Sets *path to the
    /// file read. Returns "" on success, else why the first candidate could not be read.
    std::string read_relative(const std::string &dir, const std::string &name,
                              std::string *path, std::string *text) {
        *path = join(main_dir_, name);
        std::string why = read_text_file(*path, text);
        if (why.empty()) return "";
        std::string alt = join(dir, name);
        if (alt != *path && read_text_file(alt, text).empty()) {
            *path = alt;
            return "";
        }
        return why;
    }
    void motion_warning(const FileLoc &loc) {
        if (warned_motion_) return;
        warned_motion_ = true;
        warn(loc, "motion blur is not supported: only the StartTime transform is used");
    }
    void set_option(OptionDesc &o, Tokenizer &tok, const Token &t, const std::string &dir);

    SceneDesc &scene_;
    std::string main_dir_;
    GraphicsState state_;
    std::vector<StackEntry> stack_;
    std::map<std::string, Transform> named_coord_sys_;
    bool in_world_ = false;
    bool active_start_ = true;
    bool warned_motion_ = false;
    bool warned_transform_begin_ = false;
    int anonymous_materials_ = 0;
    ObjectDesc *current_object_ = nullptr;
    std::map<std::string, int> texture_index_;  // "float:name" / "spectrum:name" -> index
};

Param Parser::parse_param(Tokenizer &tok, const Token &decl, const std::string &dir) {
    Param p;
    p.loc = tok.loc(decl);
    // "type name": exactly two words.
    std::istringstream words(decl.text);
    std::string extra;
    if (!(words >> p.type >> p.name) || (words >> extra))
        throw SceneError(p.loc, "bad parameter declaration \"" + decl.text +
                                    "\": expected \"type name\"");
    if (p.type == "point") p.type = "point3";
    else if (p.type == "vector") p.type = "vector3";
    else if (p.type == "normal3") p.type = "normal";
    else if (p.type == "color") {
        warn(p.loc, "parameter type \"color\" is pbrt-v3 syntax; read as \"rgb\"");
        p.type = "rgb";
    }
    static const char *kTypes[] = {"integer", "float",  "point2",    "vector2",  "point3",
                                   "vector3", "normal", "rgb",       "blackbody", "spectrum",
                                   "bool",    "string", "texture"};
    bool known = false;
    for (const char *k : kTypes) known = known || p.type == k;
    if (!known) throw SceneError(p.loc, "unknown parameter type \"" + p.type + "\"");

    // Values: [ v v v ] or one bare value.
    std::vector<Token> values;
    Token first = expect_token(tok, ("no value for parameter \"" + p.name + "\"").c_str());
    if (first.is("[")) {
        while (true) {
            Token t = expect_token(tok, ("missing ']' for parameter \"" + p.name + "\"").c_str());
            if (t.is("]")) break;
            if (t.is("["))
                throw SceneError(tok.loc(t), "unexpected '[' in values of \"" + p.name + "\"");
            values.push_back(std::move(t));
        }
    } else if (first.is("]")) {
        throw SceneError(tok.loc(first), "unexpected ']'");
    } else {
        values.push_back(std::move(first));
    }
    if (values.empty()) throw SceneError(p.loc, "no values given for parameter \"" + p.name + "\"");

    auto numbers = [&]() {
        for (const Token &v : values) {
            std::optional<double> d = to_number(v);
            if (!d)
                throw SceneError(tok.loc(v), "parameter \"" + p.type + " " + p.name +
                                                 "\" expects numbers, found " +
                                                 (v.quoted ? "\"" + v.text + "\"" : v.text));
            p.numbers.push_back(*d);
        }
    };
    auto strings = [&]() {
        for (const Token &v : values) {
            if (!v.quoted)
                throw SceneError(tok.loc(v), "parameter \"" + p.type + " " + p.name +
                                                 "\" expects quoted strings, found " + v.text);
            p.strings.push_back(v.text);
        }
    };
    auto count_multiple = [&](size_t n) {
        if (p.numbers.size() % n != 0)
            throw SceneError(p.loc, "parameter \"" + p.type + " " + p.name + "\" expects a " +
                                        "multiple of " + std::to_string(n) + " values, found " +
                                        std::to_string(p.numbers.size()));
    };

    if (p.type == "string" || p.type == "texture") {
        strings();
        if (p.type == "texture" && p.strings.size() != 1)
            throw SceneError(p.loc, "parameter \"texture " + p.name + "\" expects one texture "
                                    "name, found " + std::to_string(p.strings.size()));
    } else if (p.type == "bool") {
        for (const Token &v : values) {
            if (v.text == "true") p.bools.push_back(1);
            else if (v.text == "false") p.bools.push_back(0);
            else
                throw SceneError(tok.loc(v), "parameter \"bool " + p.name +
                                                 "\" expects true or false, found " + v.text);
        }
    } else if (p.type == "spectrum") {
        if (values[0].quoted) {
            strings();
            if (p.strings.size() != 1)
                throw SceneError(p.loc, "parameter \"spectrum " + p.name +
                                            "\" expects one spectrum name or file name");
            const std::string &s = p.strings[0];
            if (!named_spectrum_rgb(s)) {
                // Not a named spectrum: a file of (lambda, value) pairs, relative to this file.
                // pbrt-v4's sensor curves are left as names (reported where used).
                bool sensor = s.starts_with("canon_") || s.starts_with("nikon_") ||
                              s.starts_with("sony_") || s.starts_with("hasselblad_");
                std::string text, path;
                if (!sensor) {
                    std::string why = read_relative(dir, s, &path, &text);
                    if (!why.empty())
                        throw SceneError(p.loc, "spectrum \"" + s +
                                                    "\" is neither a named spectrum nor a "
                                                    "readable file (" + why + ")");
                    scene_.read_files.push_back(path);
                    Tokenizer st(text, path);
                    while (std::optional<Token> t = st.next()) {
                        std::optional<double> d = to_number(*t);
                        if (!d)
                            throw SceneError(st.loc(*t), "bad number '" + t->text +
                                                             "' in spectrum file");
                        p.numbers.push_back(*d);
                    }
                    if (p.numbers.size() < 2 || p.numbers.size() % 2 != 0)
                        throw SceneError(p.loc, "spectrum file \"" + s +
                                                    "\" must hold (lambda, value) pairs");
                    p.strings.clear();
                }
            }
        } else {
            numbers();
            if (p.numbers.size() < 2) count_multiple(2);
            count_multiple(2);
            for (size_t i = 2; i < p.numbers.size(); i += 2)
                if (!(p.numbers[i] > p.numbers[i - 2]))
                    throw SceneError(p.loc, "parameter \"spectrum " + p.name +
                                                "\": wavelengths must increase");
        }
    } else {
        numbers();
        if (p.type == "integer") {
            for (size_t i = 0; i < p.numbers.size(); ++i) {
                double v = p.numbers[i];
                if (v != std::floor(v))
                    throw SceneError(tok.loc(values[i]), "parameter \"integer " + p.name +
                                                             "\" has a non-integer value " +
                                                             values[i].text);
                // Integers are 32-bit (pbrt-v4's int); converting a larger value is undefined.
                if (v < double(INT_MIN) || v > double(INT_MAX))
                    throw SceneError(tok.loc(values[i]),
                                     "parameter \"integer " + p.name + "\" value " +
                                         values[i].text + " is out of the 32-bit integer range");
            }
        } else if (p.type == "point2" || p.type == "vector2") {
            count_multiple(2);
        } else if (p.type == "point3" || p.type == "vector3" || p.type == "normal" ||
                   p.type == "rgb") {
            count_multiple(3);
        } else if (p.type == "blackbody") {
            if (p.numbers.size() != 1 && p.numbers.size() != 2)
                throw SceneError(p.loc, "parameter \"blackbody " + p.name +
                                            "\" expects one temperature (K), found " +
                                            std::to_string(p.numbers.size()) + " values");
        }
    }
    return p;
}

ParamSet Parser::parse_params(Tokenizer &tok, const std::string &dir) {
    ParamSet ps;
    while (const Token *t = tok.peek()) {
        if (!t->quoted) break;
        Token decl = *tok.next();
        Param p = parse_param(tok, decl, dir);
        if (ps.find(p.name))
            throw SceneError(p.loc, "parameter \"" + p.name + "\" given twice");
        ps.params.push_back(std::move(p));
    }
    return ps;
}

void Parser::pop(Tokenizer &tok, const Token &t, PushKind kind) {
    if (stack_.empty())
        throw SceneError(tok.loc(t), "unmatched " + t.text + " (no " + push_name(kind) + ")");
    StackEntry &top = stack_.back();
    if (top.kind != kind)
        throw SceneError(tok.loc(t), t.text + " does not match the open " +
                                         push_name(top.kind) + " at " + top.loc.str());
    if (kind == PushKind::Transform) {
        // TransformEnd restores only the CTM.
        state_.ctm = top.state.ctm;
    } else {
        state_ = std::move(top.state);
    }
    stack_.pop_back();
}

void Parser::set_option(OptionDesc &o, Tokenizer &tok, const Token &t, const std::string &dir) {
    require_options(tok, t);
    std::string type = expect_string(tok, t.text);
    ParamSet params = parse_params(tok, dir);
    if (o.present) warn(tok.loc(t), t.text + " given again; the earlier one at " + o.loc.str() +
                                        " is replaced");
    o.type = type;
    o.params = std::move(params);
    o.loc = tok.loc(t);
    o.present = true;
}

bool Parser::transform_directive(Tokenizer &tok, const Token &t, const FileLoc &loc) {
    const std::string &d = t.text;
    if (d == "Identity") {
        set_transform(Transform());
    } else if (d == "Translate") {
        std::vector<double> v = expect_numbers(tok, d, 3);
        apply_transform(Transform::translate(Vec3f(float(v[0]), float(v[1]), float(v[2]))));
    } else if (d == "Scale") {
        std::vector<double> v = expect_numbers(tok, d, 3);
        apply_transform(Transform::scale(v[0], v[1], v[2]));
    } else if (d == "Rotate") {
        std::vector<double> v = expect_numbers(tok, d, 4);
        apply_transform(
            Transform::rotate(v[0], Vec3f(float(v[1]), float(v[2]), float(v[3]))));
    } else if (d == "LookAt") {
        std::vector<double> v = expect_numbers(tok, d, 9);
        bool ok = true;
        Transform la = Transform::look_at(Vec3f(float(v[0]), float(v[1]), float(v[2])),
                                          Vec3f(float(v[3]), float(v[4]), float(v[5])),
                                          Vec3f(float(v[6]), float(v[7]), float(v[8])), &ok);
        // pbrt-v4 stops on a LookAt it cannot turn into a frame; so does Tessera (a
        // silently ignored camera transform renders a black or wrong image).
        if (!ok) {
            const bool same = v[0] == v[3] && v[1] == v[4] && v[2] == v[5];
            throw SceneError(loc, same ? "LookAt: the eye and the look-at point are the "
                                         "same; there is no viewing direction"
                                       : "LookAt: the up vector is zero or parallel to the "
                                         "viewing direction");
        }
        apply_transform(la);
    } else if (d == "Transform" || d == "ConcatTransform") {
        std::vector<double> v = expect_numbers(tok, d, 16);
        Mat4 m;
        // Column by column in the file: element i is row i % 4, column i / 4.
        for (int i = 0; i < 16; ++i) m.m[i % 4][i / 4] = v[i];
        if (d == "Transform") set_transform(Transform(m));
        else apply_transform(Transform(m));
    } else if (d == "CoordinateSystem") {
        named_coord_sys_[expect_string(tok, d)] = state_.ctm;
    } else if (d == "CoordSysTransform") {
        std::string name = expect_string(tok, d);
        auto it = named_coord_sys_.find(name);
        if (it == named_coord_sys_.end())
            warn(loc, "CoordSysTransform: unknown coordinate system \"" + name + "\"");
        else
            set_transform(it->second);
    } else if (d == "TransformTimes") {
        expect_numbers(tok, d, 2);
        motion_warning(loc);
    } else if (d == "ActiveTransform") {
        Token a = expect_token(tok, "ActiveTransform expects StartTime, EndTime or All");
        if (a.is("StartTime") || a.is("All")) {
            active_start_ = true;
        } else if (a.is("EndTime")) {
            active_start_ = false;
            motion_warning(loc);
        } else {
            throw SceneError(tok.loc(a), "ActiveTransform expects StartTime, EndTime or "
                                         "All, found '" + a.text + "'");
        }
    } else if (d == "ReverseOrientation") {
        state_.reverse_orientation = !state_.reverse_orientation;
    } else {
        return false;
    }
    return true;
}

bool Parser::block_directive(Tokenizer &tok, const Token &t, const FileLoc &loc,
                             const std::string &dir) {
    const std::string &d = t.text;
    if (d == "AttributeBegin") {
        push(PushKind::Attribute, loc);
    } else if (d == "AttributeEnd") {
        pop(tok, t, PushKind::Attribute);
    } else if (d == "TransformBegin") {
        if (!warned_transform_begin_)
            warn(loc, "TransformBegin/TransformEnd are deprecated in pbrt-v4; accepted");
        warned_transform_begin_ = true;
        push(PushKind::Transform, loc);
    } else if (d == "TransformEnd") {
        pop(tok, t, PushKind::Transform);
    } else if (d == "Attribute") {
        std::string target = expect_string(tok, d);
        ParamSet ps = parse_params(tok, dir);
        ParamSet *attrs = target == "shape"      ? &state_.shape_attrs
                          : target == "light"    ? &state_.light_attrs
                          : target == "material" ? &state_.material_attrs
                          : target == "medium"   ? &state_.medium_attrs
                          : target == "texture"  ? &state_.texture_attrs
                                                 : nullptr;
        if (!attrs)
            throw SceneError(loc, "Attribute: unknown target \"" + target +
                                      "\" (expected shape, light, material, medium or "
                                      "texture)");
        // Later Attribute statements override earlier values of the same name.
        for (Param &p : ps.params) {
            std::erase_if(attrs->params, [&](const Param &q) { return q.name == p.name; });
            attrs->params.push_back(std::move(p));
        }
    } else if (d == "WorldBegin") {
        if (in_world_) throw SceneError(loc, "WorldBegin given twice");
        in_world_ = true;
        active_start_ = true;  // pbrt-v4 resets the active transforms too
        state_.ctm = Transform();
        named_coord_sys_["world"] = state_.ctm;
    } else if (d == "WorldEnd") {
        warn(loc, "WorldEnd is pbrt-v3 syntax; ignored");
    } else {
        return false;
    }
    return true;
}

bool Parser::option_directive(Tokenizer &tok, const Token &t, const FileLoc &loc,
                              const std::string &dir) {
    const std::string &d = t.text;
    if (d == "Camera") {
        set_option(scene_.camera, tok, t, dir);
        scene_.camera_from_world = state_.ctm;
        scene_.camera_medium = state_.medium_outside;
        scene_.camera_medium_loc = state_.medium_loc;
        named_coord_sys_["camera"] = state_.ctm.inverse();
    } else if (d == "Film") {
        set_option(scene_.film, tok, t, dir);
    } else if (d == "Sampler") {
        set_option(scene_.sampler, tok, t, dir);
    } else if (d == "Integrator") {
        set_option(scene_.integrator, tok, t, dir);
    } else if (d == "PixelFilter") {
        set_option(scene_.filter, tok, t, dir);
    } else if (d == "Accelerator") {
        set_option(scene_.accelerator, tok, t, dir);
    } else if (d == "ColorSpace") {
        std::string cs = expect_string(tok, d);
        if (cs != "srgb")
            warn(loc, "ColorSpace \"" + cs + "\" is not supported; colours are read as "
                      "linear sRGB");
    } else if (d == "Option") {
        ParamSet ps = parse_params(tok, dir);
        if (ps.params.size() != 1)
            throw SceneError(loc, "Option expects exactly one parameter");
        warn(loc, "Option \"" + ps.params[0].name + "\" is not supported; ignored");
    } else {
        return false;
    }
    return true;
}

void Parser::include_directive(Tokenizer &tok, const Token &t, const FileLoc &loc,
                               const std::string &dir, int depth) {
    const std::string &d = t.text;
    // Include is textual. Import (pbrt-v4) is allowed in the world block only and
    // brings back the shapes, lights, instances and named entities it declares, not its
    // graphics state: a transform, material or ReverseOrientation left set at the end of
    // the imported file does not carry over.
    const bool import = d == "Import";
    if (import) require_world(tok, t);
    std::string name = expect_string(tok, d);
    if (depth + 1 > kMaxIncludeDepth)
        throw SceneError(loc, d + " nested more than " +
                                  std::to_string(kMaxIncludeDepth) + " files deep");
    std::string path, text;
    std::string why = read_relative(dir, name, &path, &text);
    if (!why.empty())
        throw SceneError(loc, "cannot open " + d + " file \"" + name + "\": " + why);
    // A file that includes itself, directly or through others, would recurse until
    // the depth limit: name the cycle instead.
    std::string id = canonical_or_same(path);
    for (size_t i = 0; i < include_stack_.size(); ++i) {
        if (include_stack_[i].id != id) continue;
        std::string chain;
        for (size_t j = i; j < include_stack_.size(); ++j)
            chain += include_stack_[j].name + " -> ";
        throw SceneError(loc, d + " \"" + name + "\" includes itself (" + chain +
                                  name + ")");
    }
    scene_.read_files.push_back(path);
    include_stack_.push_back({id, path});
    Tokenizer sub(std::move(text), path);
    std::optional<GraphicsState> saved;
    const bool saved_active_start = active_start_;
    if (import) saved = state_;
    parse(sub, dir_of(path), depth + 1);
    if (saved) {
        state_ = std::move(*saved);
        active_start_ = saved_active_start;  // ActiveTransform is state too
    }
    include_stack_.pop_back();
}

bool Parser::material_directive(Tokenizer &tok, const Token &t, const FileLoc &loc,
                                const std::string &dir) {
    const std::string &d = t.text;
    if (d == "MakeNamedMaterial") {
        require_world(tok, t);
        std::string name = expect_string(tok, d);
        MaterialDesc m;
        m.name = name;
        m.params = parse_params(tok, dir);
        merge_defaults(m.params, state_.material_attrs);
        m.loc = loc;
        m.base_dir = main_dir_;  // pbrt-v4: relative to the main file
        const Param *type = m.params.find("type");
        if (!type || type->type != "string" || type->strings.size() != 1)
            throw SceneError(loc, "MakeNamedMaterial \"" + name +
                                      "\": no \"string type\" parameter");
        m.type = type->strings[0];
        std::erase_if(m.params.params, [](const Param &p) { return p.name == "type"; });
        auto [it, inserted] = scene_.materials.emplace(name, std::move(m));
        if (!inserted)
            throw SceneError(loc, "named material \"" + name + "\" redefined (first at " +
                                      it->second.loc.str() + ")");
    } else if (d == "Material") {
        require_world(tok, t);
        MaterialDesc m;
        m.type = expect_string(tok, d);
        m.params = parse_params(tok, dir);
        merge_defaults(m.params, state_.material_attrs);
        m.loc = loc;
        m.base_dir = main_dir_;  // pbrt-v4: relative to the main file
        m.name = "anonymous#" + std::to_string(++anonymous_materials_);
        state_.material = m.name;
        scene_.materials.emplace(m.name, std::move(m));
    } else if (d == "NamedMaterial") {
        require_world(tok, t);
        state_.material = expect_string(tok, d);
    } else if (d == "Texture") {
        require_world(tok, t);
        TextureDesc tx;
        tx.name = expect_string(tok, d);
        tx.value_type = expect_string(tok, d);
        tx.tex_class = expect_string(tok, d);
        if (tx.value_type == "color") {
            warn(loc, "texture type \"color\" is pbrt-v3 syntax; read as \"spectrum\"");
            tx.value_type = "spectrum";
        }
        if (tx.value_type != "float" && tx.value_type != "spectrum")
            throw SceneError(loc, "texture \"" + tx.name + "\": unknown type \"" +
                                      tx.value_type + "\" (expected float or spectrum)");
        tx.params = parse_params(tok, dir);
        merge_defaults(tx.params, state_.texture_attrs);
        tx.loc = loc;
        tx.render_from_texture = state_.ctm;
        tx.base_dir = main_dir_;  // pbrt-v4: relative to the main file
        std::string key = tx.value_type + ":" + tx.name;
        if (auto it = texture_index_.find(key); it != texture_index_.end())
            throw SceneError(loc, tx.value_type + " texture \"" + tx.name +
                                      "\" redefined (first at " +
                                      scene_.textures[it->second].loc.str() + ")");
        texture_index_[key] = int(scene_.textures.size());
        scene_.textures.push_back(std::move(tx));
    } else {
        return false;
    }
    return true;
}

bool Parser::world_directive(Tokenizer &tok, const Token &t, const FileLoc &loc,
                             const std::string &dir) {
    const std::string &d = t.text;
    if (d == "LightSource") {
        require_world(tok, t);
        LightDesc l;
        l.type = expect_string(tok, d);
        l.params = parse_params(tok, dir);
        merge_defaults(l.params, state_.light_attrs);
        l.loc = loc;
        l.render_from_light = state_.ctm;
        l.base_dir = main_dir_;  // pbrt-v4: relative to the main file
        if (current_object_)
            warn(loc, "LightSource inside ObjectBegin applies to the world, not to "
                      "instances");
        scene_.lights.push_back(std::move(l));
    } else if (d == "AreaLightSource") {
        require_world(tok, t);
        state_.area_light_type = expect_string(tok, d);
        state_.area_light = parse_params(tok, dir);
        merge_defaults(state_.area_light, state_.light_attrs);
        state_.area_light_loc = loc;
    } else if (d == "Shape") {
        require_world(tok, t);
        ShapeDesc s;
        s.type = expect_string(tok, d);
        s.params = parse_params(tok, dir);
        merge_defaults(s.params, state_.shape_attrs);
        s.loc = loc;
        s.render_from_object = state_.ctm;
        s.reverse_orientation = state_.reverse_orientation;
        s.material = state_.material;
        s.medium_inside = state_.medium_inside;
        s.medium_outside = state_.medium_outside;
        s.base_dir = main_dir_;  // pbrt-v4: relative to the main file
        if (!state_.area_light_type.empty()) {
            if (current_object_) {
                warn(loc, "area lights are not supported with object instancing; the "
                          "shape is not emissive");
            } else {
                s.area_light = state_.area_light;
                s.area_light_type = state_.area_light_type;
                s.area_light_loc = state_.area_light_loc;
            }
        }
        if (current_object_) current_object_->shapes.push_back(std::move(s));
        else scene_.shapes.push_back(std::move(s));
    } else if (d == "ObjectBegin") {
        require_world(tok, t);
        std::string name = expect_string(tok, d);
        if (current_object_)
            throw SceneError(loc, "ObjectBegin \"" + name + "\" inside the definition of \"" +
                                      current_object_->name + "\"");
        if (auto it = scene_.objects.find(name); it != scene_.objects.end())
            throw SceneError(loc, "object \"" + name + "\" redefined (first at " +
                                      it->second.loc.str() + ")");
        push(PushKind::Object, loc);
        ObjectDesc &o = scene_.objects[name];
        o.name = name;
        o.loc = loc;
        current_object_ = &o;
    } else if (d == "ObjectEnd") {
        require_world(tok, t);
        if (!current_object_) throw SceneError(loc, "ObjectEnd without ObjectBegin");
        pop(tok, t, PushKind::Object);
        current_object_ = nullptr;
    } else if (d == "ObjectInstance") {
        require_world(tok, t);
        std::string name = expect_string(tok, d);
        if (current_object_)
            throw SceneError(loc, "ObjectInstance inside the definition of object \"" +
                                      current_object_->name + "\"");
        scene_.instances.push_back({name, state_.ctm, loc});
    } else {
        return false;
    }
    return true;
}

bool Parser::medium_directive(Tokenizer &tok, const Token &t, const FileLoc &loc,
                              const std::string &dir) {
    const std::string &d = t.text;
    if (d == "MakeNamedMedium") {
        std::string name = expect_string(tok, d);
        ParamSet ps = parse_params(tok, dir);
        const Param *type = ps.find("type");
        if (!type || type->type != "string" || type->strings.size() != 1)
            throw SceneError(loc, "MakeNamedMedium \"" + name +
                                      "\": no \"string type\" parameter");
        const std::string &t = type->strings[0];
        static const char *kMediumTypes[] = {"homogeneous", "uniformgrid", "rgbgrid", "cloud",
                                             "nanovdb"};
        if (std::find(std::begin(kMediumTypes), std::end(kMediumTypes), t) ==
            std::end(kMediumTypes))
            throw SceneError(type->loc, "MakeNamedMedium \"" + name + "\": unknown medium type \"" +
                                            t + "\"");
        if (auto it = scene_.media.find(name); it != scene_.media.end())
            throw SceneError(loc, "named medium \"" + name + "\" redefined (first at " +
                                      it->second.loc.str() + ")");
        merge_defaults(ps, state_.medium_attrs);
        MediumDesc &m = scene_.media[name];
        m.name = name;
        m.type = t;
        m.params = std::move(ps);
        m.params.find("type")->used = true;
        m.loc = loc;
        m.render_from_medium = state_.ctm;
        m.base_dir = main_dir_;  // pbrt-v4: relative to the main file
    } else if (d == "MediumInterface") {
        // pbrt-v4: one name is both sides; two are inside, then outside.
        std::string inside = expect_string(tok, d), outside = inside;
        const Token *p = tok.peek();
        if (p && p->quoted) outside = tok.next()->text;
        state_.medium_inside = inside;
        state_.medium_outside = outside;
        state_.medium_loc = loc;
    } else {
        return false;
    }
    return true;
}

void Parser::parse(Tokenizer &tok, const std::string &dir, int depth) {
    while (std::optional<Token> ot = tok.next()) {
        const Token &t = *ot;
        FileLoc loc = tok.loc(t);
        if (t.quoted)
            throw SceneError(loc, "unexpected string \"" + t.text + "\" (expected a directive)");
        const std::string &d = t.text;
        if (transform_directive(tok, t, loc) || block_directive(tok, t, loc, dir) ||
            option_directive(tok, t, loc, dir))
            continue;
        if (d == "Include" || d == "Import") {
            include_directive(tok, t, loc, dir, depth);
            continue;
        }
        if (!(material_directive(tok, t, loc, dir) || world_directive(tok, t, loc, dir) ||
              medium_directive(tok, t, loc, dir)))
            throw SceneError(loc, "unknown directive '" + d + "'");
    }
}

void Parser::finish(const Tokenizer &main) {
    // pbrt-v4 (BasicSceneBuilder::EndOfFiles) rejects a missing end too: the scopes of
    // everything after it would be wrong.
    if (current_object_)
        throw SceneError(current_object_->loc, "ObjectBegin \"" + current_object_->name +
                                                   "\" without ObjectEnd");
    if (!stack_.empty())
        throw SceneError(stack_.back().loc, std::string(push_name(stack_.back().kind)) +
                                                " without a matching end");
    if (!in_world_) warn(main.loc(main.line()), "no WorldBegin: the scene is empty");
    auto check_material = [&](const ShapeDesc &s) {
        if (!s.material.empty() && !scene_.materials.count(s.material))
            throw SceneError(s.loc, "named material \"" + s.material + "\" is not defined");
    };
    for (const ShapeDesc &s : scene_.shapes) check_material(s);
    for (const auto &[name, o] : scene_.objects)
        for (const ShapeDesc &s : o.shapes) check_material(s);
    // pbrt-v4 looks media up when it creates the camera and the shapes, after the whole file
    // is read: a medium may be named before it is made.
    auto check_medium = [&](const std::string &m, const FileLoc &loc) {
        if (!m.empty() && !scene_.media.count(m))
            throw SceneError(loc, "medium \"" + m + "\" is not defined");
    };
    check_medium(scene_.camera_medium, scene_.camera_medium_loc);
    for (const ShapeDesc &s : scene_.shapes) {
        check_medium(s.medium_inside, s.loc);
        check_medium(s.medium_outside, s.loc);
    }
    for (const auto &[name, o] : scene_.objects)
        for (const ShapeDesc &s : o.shapes) {
            check_medium(s.medium_inside, s.loc);
            check_medium(s.medium_outside, s.loc);
        }
    for (const InstanceDesc &i : scene_.instances)
        if (!scene_.objects.count(i.object))
            throw SceneError(i.loc, "object \"" + i.object + "\" is not defined");
}

SceneDesc parse_text(std::string text, const std::string &file, const std::string &dir,
                     const std::string &main_file) {
    SceneDesc scene;
    scene.main_file = main_file;
    Parser parser(scene, dir);
    parser.include_stack_.push_back({canonical_or_same(file), file});
    Tokenizer tok(std::move(text), file);
    parser.parse(tok, dir, 0);
    parser.finish(tok);
    return scene;
}

}  // namespace

SceneDesc parse_pbrt_file(const std::string &path) {
    std::string text;
    if (std::string why = read_text_file(path, &text); !why.empty())
        throw SceneError(path + ":0: cannot open the scene file: " + why);
    return parse_text(std::move(text), path, dir_of(path), path);
}

SceneDesc parse_pbrt_string(const std::string &text, const std::string &filename_for_messages,
                            const std::string &base_dir) {
    return parse_text(text, filename_for_messages, base_dir, filename_for_messages);
}

}  // namespace tessera
