#include "renderer/util/json_io.h"

#include <fstream>
#include <stdexcept>

#include "renderer/util/image_io.h"

namespace tessera {

void write_json_atomic(const std::string &path, const nlohmann::json &j) {
    write_atomically(path, [&](const std::string &tmp) {
        std::ofstream f(tmp);
        f << j.dump(2) << "\n";
        f.flush();
        if (!f)
            throw std::runtime_error(path + ": cannot write");
        // Close before the last check: a full disk may show only when the buffer is written.
        f.close();
        if (f.fail())
            throw std::runtime_error(path + ": cannot write (closing the file failed)");
    });
}

}  // namespace tessera
