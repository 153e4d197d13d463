// url_probe: the C++ side of the LCM URL rule (pof/bus/url.hpp) as text, for the Python mirror's
// test (tests/python/test_pofkit.py, UrlRules): for each argument, one line
//   resolved \t group \t port \t ttl \t recv_buf_size \t error
// where resolved = pof::bus::resolve_url(argument) (so "" reads $LCM_DEFAULT_URL) and the fields
// are pof::bus::parse_udpm_url(argument) (its error text, "" when valid).
#include <cstdio>
#include <string>

#include "pof/bus/url.hpp"

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string url = argv[i];
    const pof::bus::UdpmUrl u = pof::bus::parse_udpm_url(url);
    std::printf("%s\t%s\t%u\t%d\t%d\t%s\n", pof::bus::resolve_url(url).c_str(), u.group.c_str(),
                static_cast<unsigned>(u.port), u.ttl, u.recv_buf_size, u.error.c_str());
  }
  return 0;
}
