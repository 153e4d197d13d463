// `git describe` of the sources built. Alone in its file: the description changes with every commit,
// and a file that includes nothing recompiles in a fraction of a second (the CLI's files, unity
// batched, take tens of seconds each: CMakeLists.txt, POF_UNITY_BUILD).
namespace pof::cli {

const char* git_describe() { return POF_GIT_DESCRIBE; }

}  // namespace pof::cli
