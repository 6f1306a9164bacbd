// @file layers/probe.cpp
// @brief One include, ISOLOFT_PROBE, compiled as a source of one layer
// (tests/CMakeLists.txt, layer probes): a header of a higher layer must not
// be found, one of a lower layer must compile.
#include ISOLOFT_PROBE

int isoloft_layer_probe() { return 0; }
