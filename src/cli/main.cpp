// cbdpt command line: `cbdpt render SCENE [options]`, `cbdpt compare IMAGE REFERENCE`,
// `cbdpt info [SCENE]`, `cbdpt merge STATE... -o IMAGE` and `cbdpt combine IMAGE... -o OUT`.
//
// Each command lives in its own file, src/cli/NAME_command.cpp, which defines
// `Command addNameCommand(CLI::App& app)` (declared in cli/commands.h): it adds its subcommand
// and options to the app and returns a function that runs it. To add a command, write that
// file and add its add function to the list below; main only parses and dispatches.
#include "cbdpt_git_revision.h" // CBDPT_GIT_REVISION, written at every build
#include "cl/cl_runtime.h"
#include "cli/commands.h"
#include "scene/scene_desc.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <cstdio>
#include <exception>
#include <vector>

namespace {

// OpenCL reports failures by status; name it, and say what to do when memory ran out or a
// kernel faulted (NVIDIA's driver reports a faulting kernel at the next call that waits for it).
void printOpenClError(const cl::Error& e) {
    const bool outOfMemory = e.err() == CL_MEM_OBJECT_ALLOCATION_FAILURE ||
                             e.err() == CL_OUT_OF_RESOURCES || e.err() == CL_OUT_OF_HOST_MEMORY ||
                             e.err() == CL_INVALID_BUFFER_SIZE;
    const bool faulted = e.err() == CL_OUT_OF_RESOURCES || e.err() == CL_INVALID_COMMAND_QUEUE;
    fmt::print(stderr, "cbdpt: error: OpenCL call {} failed with {}{}{}\n", e.what(),
               cb::clStatusName(e.err()),
               outOfMemory ? ": the device ran out of memory (try a smaller --width/--height "
                             "or lower vertex caps)"
                           : "",
               faulted ? "; on a GPU a kernel that faulted is reported so too (NVIDIA: "
                         "CBDPT_KERNEL_OPTIONS=-cl-opt-disable, see docs/gpu.md)"
                       : "");
}

// `cbdpt --version`: the version, the git revision the build was configured from, and the
// OpenCL platforms.
void printVersion() {
    fmt::print("cbdpt {} (git {})\n", CBDPT_VERSION, CBDPT_GIT_REVISION);
    try {
        std::vector<cl::Platform> platforms;
        cl::Platform::get(&platforms);
        for (const auto& p : platforms)
            fmt::print("OpenCL platform: {} | {}\n", p.getInfo<CL_PLATFORM_NAME>(),
                       p.getInfo<CL_PLATFORM_VERSION>());
        if (platforms.empty()) fmt::print("OpenCL platform: none found\n");
    } catch (const cl::Error& e) {
        fmt::print("OpenCL platform: none found ({})\n", cb::clStatusName(e.err()));
    }
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"cbdpt - coherent bidirectional path tracing on OpenCL"};
    app.add_flag_callback(
        "--version",
        [] {
            printVersion();
            throw CLI::Success();
        },
        "print the version, the git revision and the OpenCL platforms");
    app.require_subcommand(1);
    const std::vector<cb::cli::Command> commands = {
        cb::cli::addRenderCommand(app), cb::cli::addCompareCommand(app),
        cb::cli::addInfoCommand(app),   cb::cli::addCombineCommand(app),
        cb::cli::addMergeCommand(app),
    };
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // CLI11 prints the message (or --help); a wrong command line exits 2, as the scripts do.
        return app.exit(e) == 0 ? 0 : 2;
    }
    try {
        for (const auto& command : commands)
            if (*command.subcommand) return command.run();
    } catch (const cl::Error& e) {
        printOpenClError(e);
        return 1;
    } catch (const std::exception& e) {
        fmt::print(stderr, "cbdpt: error: {}\n", cb::printableText(e.what()));
        return 1;
    }
    return 0;
}
