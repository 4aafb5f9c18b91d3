#include "tools/cli.h"

int main(int argc, char** argv) { return turbid::RunCli(argc, argv); }
