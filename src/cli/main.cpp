// cbdpt command line: `cbdpt render SCENE [options]`, `cbdpt compare IMAGE REFERENCE`,
// `cbdpt info [SCENE]` and `cbdpt merge STATE... -o IMAGE`.
//
// Each command lives in its own file, src/cli/NAME_command.cpp, which defines
// `Command addNameCommand(CLI::App& app)` (declared in cli/commands.h): it adds its subcommand
// and options to the app and returns a function that runs it. To add a command, write that
// file and add its add function to the list below; main only parses and dispatches.
#include "cl/cl_runtime.h"
#include "cli/commands.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <cstdio>
#include <exception>
#include <vector>

namespace {

// OpenCL reports failures by status; name it, and say what to do when memory ran out.
void printOpenClError(const cl::Error& e) {
    const bool outOfMemory = e.err() == CL_MEM_OBJECT_ALLOCATION_FAILURE ||
                             e.err() == CL_OUT_OF_RESOURCES || e.err() == CL_OUT_OF_HOST_MEMORY ||
                             e.err() == CL_INVALID_BUFFER_SIZE;
    fmt::print(stderr, "cbdpt: error: OpenCL call {} failed with {}{}\n", e.what(),
               cb::clStatusName(e.err()),
               outOfMemory ? ": the device ran out of memory (try a smaller --width/--height "
                             "or lower vertex caps)"
                           : "");
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"cbdpt - coherent bidirectional path tracing on OpenCL"};
    app.require_subcommand(1);
    const std::vector<cb::cli::Command> commands = {
        cb::cli::addRenderCommand(app),
        cb::cli::addCompareCommand(app),
        cb::cli::addInfoCommand(app),
        cb::cli::addMergeCommand(app),
    };
    CLI11_PARSE(app, argc, argv);
    try {
        for (const auto& command : commands)
            if (*command.subcommand) return command.run();
    } catch (const cl::Error& e) {
        printOpenClError(e);
        return 1;
    } catch (const std::exception& e) {
        fmt::print(stderr, "cbdpt: error: {}\n", e.what());
        return 1;
    }
    return 0;
}
