#pragma once
#include "Arduino.h"
class Servo {
 public:
  void attach(int pin) { pin_ = pin; }
  void write(int degrees) { std::fprintf(stderr, "SERVO %d %d\n", pin_, degrees); }
 private:
  int pin_ = -1;
};
