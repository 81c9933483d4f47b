// AOV set names: parsing and printing `--aov` lists.
#include "sampling/aov_set.h"

#include <stdexcept>

namespace tessera::sampling {

const char *aov_name(Aov a) {
    switch (a) {
        case Aov::Albedo:
            return "albedo";
        case Aov::Normal:
            return "normal";
        case Aov::Depth:
            return "depth";
    }
    return "?";
}

std::vector<std::string> AovSet::names() const {
    std::vector<std::string> out;
    for (Aov a : kAllAovs)
        if (has(a))
            out.emplace_back(aov_name(a));
    return out;
}

std::string AovSet::describe() const {
    if (empty())
        return "none";
    std::string s;
    for (const std::string &n : names())
        s += (s.empty() ? "" : ",") + n;
    return s;
}

AovSet AovSet::parse(const std::string &text) {
    if (text == "all")
        return all();
    if (text == "none")
        return {};
    AovSet set;
    size_t start = 0;
    while (true) {
        size_t comma = text.find(',', start);
        std::string item = text.substr(start, comma == std::string::npos ? comma : comma - start);
        bool known = false;
        for (Aov a : kAllAovs)
            if (item == aov_name(a)) {
                set = set.with(a);
                known = true;
            }
        // "all" and "none" stand alone: inside a list they are more likely a mistake.
        if (!known)
            throw std::invalid_argument("unknown AOV \"" + item +
                                        "\" (expected a comma list of albedo, normal, depth, "
                                        "or all, or none)");
        if (comma == std::string::npos)
            break;
        start = comma + 1;
    }
    return set;
}

}  // namespace tessera::sampling
