// Host-side stand-in for the Arduino core, just enough to compile and run masonry_actuators.ino on a PC
// (tests/test_arduino_firmware.py): Serial is stdin/stdout, pin and servo changes are logged on stderr.
#pragma once
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#define HIGH 1
#define LOW 0
#define INPUT 0
#define OUTPUT 1
#define INPUT_PULLUP 2
#define LED_BUILTIN 13

unsigned long millis();
void pinMode(int pin, int mode);
void digitalWrite(int pin, int value);
int digitalRead(int pin);

struct HostSerial {
  void begin(long baud);
  int available();
  int read();
  void print(const char *text);
  explicit operator bool() const { return true; }
};
extern HostSerial Serial;
