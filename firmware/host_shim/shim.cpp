#include "Arduino.h"
#include <chrono>
#include <unistd.h>

HostSerial Serial;
static int pending = -1;
static bool input_closed = false;
static int pins[64];

unsigned long millis() {
  using namespace std::chrono;
  static const auto start = steady_clock::now();
  return (unsigned long)duration_cast<milliseconds>(steady_clock::now() - start).count();
}
void pinMode(int pin, int mode) { pins[pin] = (mode == INPUT_PULLUP) ? HIGH : LOW; }
void digitalWrite(int pin, int value) {
  if (pins[pin] != value) std::fprintf(stderr, "PIN %d %d\n", pin, value);
  pins[pin] = value;
}
int digitalRead(int pin) {
  const char *attached = std::getenv("MASONRY_SHIM_ATTACHED");  // the brick sensor, from the test
  if (attached != nullptr && pin == 2) return attached[0] == '1' ? LOW : HIGH;
  return pins[pin];
}
void HostSerial::begin(long) {}
int HostSerial::available() {
  if (pending < 0 && !input_closed) {
    char c;
    if (::read(0, &c, 1) == 1) pending = (unsigned char)c;
    else input_closed = true;
  }
  return pending >= 0 ? 1 : 0;
}
int HostSerial::read() {
  int c = pending;
  pending = -1;
  return c;
}
void HostSerial::print(const char *text) {
  std::fputs(text, stdout);
  std::fflush(stdout);
}

void setup();
void loop();
int main() {
  setup();
  while (!input_closed) loop();
  return 0;
}
