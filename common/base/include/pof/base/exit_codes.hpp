#pragma once
// Process exit codes shared by every pofkit binary (sysexits.h values, which the brief fixes).
namespace pof {

enum ExitCode : int {
  kExitOk = 0,
  kExitUsage = 2,         // bad command line (CLI11 also uses this)
  kExitDataErr = 65,      // input data malformed (EX_DATAERR): names file and line
  kExitNoInput = 66,      // input file missing or unreadable (EX_NOINPUT)
  kExitIoErr = 74,        // I/O error while reading or writing (EX_IOERR)
  kExitConfig = 78,       // bad configuration or calibration file (EX_CONFIG): names the key
};

}  // namespace pof
