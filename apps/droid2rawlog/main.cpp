// droid2rawlog: see dbacov/app/droid2rawlog_app.h and `droid2rawlog --help`.
#include <exception>
#include <iostream>

#include "dbacov/app/droid2rawlog_app.h"

int main(int argc, char** argv) {
  try {
    return dbacov::app::runDroid2RawlogApp(argc, argv, std::cout, std::cerr);
  } catch (const std::exception& e) {
    std::cerr << "droid2rawlog: internal error: " << e.what() << '\n';
    return 1;
  }
}
