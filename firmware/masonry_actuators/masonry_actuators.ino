// masonry actuator board: electromagnet, ball-joint lock servo, adhesive valve servo, brick sensor.
//
// Speaks the masonry actuator line protocol (src/masonry/actuator_protocol.py is the reference):
//   host -> board   <seq> <COMMAND> [ARG]*<CS>\n
//   board -> host   <seq> OK [FIELD ...]*<CS>\n   |   <seq> ERR <CODE> <message>*<CS>\n
//   at boot         HELLO masonry-actuators 1*<CS>\n
// CS = two upper-case hex digits, XOR of every byte before '*'. A repeated <seq> with the same command is
// answered from a cache without acting twice (the host re-sends on timeout).
//
// Commands: PING | MAG ON|OFF | JOINT LOCK|UNLOCK | VALVE OPEN|CLOSE | STATUS
// Board: Arduino Uno / Nano / Pro Micro (5 V). Wiring: firmware/README.md. Edit the block below to match yours.

#include <Servo.h>

// ---------------------------------------------------------------- configuration (edit to match your build)
const long BAUD = 115200;
const uint8_t MAGNET_PIN = 7;          // gate of the logic-level MOSFET (or relay input) driving the magnet
const bool MAGNET_ACTIVE_HIGH = true;  // false for active-low relay boards
const uint8_t JOINT_SERVO_PIN = 9;     // ball-joint lock servo signal
const uint8_t VALVE_SERVO_PIN = 10;    // adhesive valve servo signal
const uint8_t ATTACH_SENSOR_PIN = 2;   // switch in the conical guide, to GND when a brick is seated
const bool ATTACH_ACTIVE_LOW = true;   // INPUT_PULLUP: LOW means "brick seated"
const int JOINT_LOCK_DEG = 20;         // servo angle that locks the ball joint
const int JOINT_UNLOCK_DEG = 110;      // servo angle that frees it
const int VALVE_CLOSE_DEG = 0;         // servo angle with the valve shut
const int VALVE_OPEN_DEG = 90;         // servo angle with the valve open
const unsigned long VALVE_FAILSAFE_MS = 0;  // >0: close the valve if the host is silent this long (0: off)
const uint8_t STATUS_LED_PIN = LED_BUILTIN; // lit while the magnet is on
// ---------------------------------------------------------------------------------------------------------

const char PROTOCOL_NAME[] = "masonry-actuators";
const int PROTOCOL_VERSION = 1;
const uint8_t MAX_LINE = 96;

Servo jointServo;
Servo valveServo;
bool magnetOn = false;
bool jointLocked = true;
bool valveOpen = false;

char line[MAX_LINE + 1];
uint8_t lineLength = 0;
bool lineOverflow = false;

// cache of the last answered request: seq, command+args, reply
int lastSeq = -1;
char lastRequest[MAX_LINE + 1] = "";
char lastReply[MAX_LINE + 8] = "";
unsigned long lastHostMs = 0;

uint8_t checksumOf(const char *s, size_t n) {
  uint8_t cs = 0;
  for (size_t i = 0; i < n; i++) cs ^= (uint8_t)s[i];
  return cs;
}

// Frame body into out ("<body>*CS\n") and send it.
void sendFramed(const char *body, char *out, size_t outSize) {
  uint8_t cs = checksumOf(body, strlen(body));
  snprintf(out, outSize, "%s*%02X\n", body, cs);
  Serial.print(out);
}

void sendError(int seq, const char *code, const char *message, char *out, size_t outSize) {
  char body[MAX_LINE + 1];
  snprintf(body, sizeof(body), "%d ERR %s %s", seq, code, message);
  sendFramed(body, out, outSize);
}

bool attached() {
  int level = digitalRead(ATTACH_SENSOR_PIN);
  return ATTACH_ACTIVE_LOW ? level == LOW : level == HIGH;
}

void applyOutputs() {
  digitalWrite(MAGNET_PIN, (magnetOn == MAGNET_ACTIVE_HIGH) ? HIGH : LOW);
  digitalWrite(STATUS_LED_PIN, magnetOn ? HIGH : LOW);
  jointServo.write(jointLocked ? JOINT_LOCK_DEG : JOINT_UNLOCK_DEG);
  valveServo.write(valveOpen ? VALVE_OPEN_DEG : VALVE_CLOSE_DEG);
}

// Execute one checked request; writes the framed reply into reply.
void execute(int seq, char *command, char *arg, char *extra, char *reply, size_t replySize) {
  char body[MAX_LINE + 1];
  bool hasArg = arg != NULL;
  if (extra != NULL) { sendError(seq, "BADARG", "too many arguments", reply, replySize); return; }
  if (strcmp(command, "PING") == 0 || strcmp(command, "STATUS") == 0) {
    if (hasArg) { sendError(seq, "BADARG", "takes no argument", reply, replySize); return; }
    if (command[0] == 'P') {
      snprintf(body, sizeof(body), "%d OK %s %d", seq, PROTOCOL_NAME, PROTOCOL_VERSION);
    } else {
      snprintf(body, sizeof(body), "%d OK mag=%d joint=%s valve=%s attached=%d", seq, magnetOn ? 1 : 0,
               jointLocked ? "LOCK" : "UNLOCK", valveOpen ? "OPEN" : "CLOSE", attached() ? 1 : 0);
    }
    sendFramed(body, reply, replySize);
    return;
  }
  if (strcmp(command, "MAG") == 0) {
    if (hasArg && strcmp(arg, "ON") == 0) magnetOn = true;
    else if (hasArg && strcmp(arg, "OFF") == 0) magnetOn = false;
    else { sendError(seq, "BADARG", "MAG takes ON|OFF", reply, replySize); return; }
  } else if (strcmp(command, "JOINT") == 0) {
    if (hasArg && strcmp(arg, "LOCK") == 0) jointLocked = true;
    else if (hasArg && strcmp(arg, "UNLOCK") == 0) jointLocked = false;
    else { sendError(seq, "BADARG", "JOINT takes LOCK|UNLOCK", reply, replySize); return; }
  } else if (strcmp(command, "VALVE") == 0) {
    if (hasArg && strcmp(arg, "OPEN") == 0) valveOpen = true;
    else if (hasArg && strcmp(arg, "CLOSE") == 0) valveOpen = false;
    else { sendError(seq, "BADARG", "VALVE takes OPEN|CLOSE", reply, replySize); return; }
  } else {
    snprintf(body, sizeof(body), "unknown command %s", command);
    sendError(seq, "UNKNOWN", body, reply, replySize);
    return;
  }
  applyOutputs();
  snprintf(body, sizeof(body), "%d OK", seq);
  sendFramed(body, reply, replySize);
}

void handleLine(char *text) {
  char scratch[MAX_LINE + 8];
  size_t n = strlen(text);
  while (n > 0 && (text[n - 1] == '\r' || text[n - 1] == ' ')) text[--n] = '\0';
  char *star = strrchr(text, '*');
  if (star == NULL || strlen(star + 1) != 2) { sendError(0, "BADLINE", "no checksum", scratch, sizeof(scratch)); return; }
  uint8_t expected = checksumOf(text, star - text);
  uint8_t given = (uint8_t)strtol(star + 1, NULL, 16);
  if (expected != given) { sendError(0, "BADCHK", "checksum mismatch", scratch, sizeof(scratch)); return; }
  *star = '\0';
  for (char *p = text; *p; p++) *p = toupper(*p);

  char request[MAX_LINE + 1];
  strncpy(request, text, sizeof(request));
  request[MAX_LINE] = '\0';
  char *seqText = strtok(text, " ");
  char *command = strtok(NULL, " ");
  char *arg = strtok(NULL, " ");
  char *extra = strtok(NULL, " ");
  if (seqText == NULL || command == NULL) { sendError(0, "BADLINE", "expected seq and command", scratch, sizeof(scratch)); return; }
  for (char *p = seqText; *p; p++) {
    if (!isdigit(*p)) { sendError(0, "BADLINE", "bad sequence number", scratch, sizeof(scratch)); return; }
  }
  int seq = atoi(seqText);
  if (seq > 255) { sendError(0, "BADLINE", "bad sequence number", scratch, sizeof(scratch)); return; }
  lastHostMs = millis();
  if (seq == lastSeq && strcmp(request, lastRequest) == 0) {  // a retry: same answer, no second action
    Serial.print(lastReply);
    return;
  }
  execute(seq, command, arg, extra, lastReply, sizeof(lastReply));
  lastSeq = seq;
  strncpy(lastRequest, request, sizeof(lastRequest));
}

void setup() {
  pinMode(MAGNET_PIN, OUTPUT);
  pinMode(STATUS_LED_PIN, OUTPUT);
  pinMode(ATTACH_SENSOR_PIN, ATTACH_ACTIVE_LOW ? INPUT_PULLUP : INPUT);
  jointServo.attach(JOINT_SERVO_PIN);
  valveServo.attach(VALVE_SERVO_PIN);
  applyOutputs();  // magnet off, joint locked, valve closed
  Serial.begin(BAUD);
  while (!Serial && millis() < 2000) {}  // native-USB boards: wait briefly for the host
  char scratch[48];
  char body[40];
  snprintf(body, sizeof(body), "HELLO %s %d", PROTOCOL_NAME, PROTOCOL_VERSION);
  sendFramed(body, scratch, sizeof(scratch));
  lastHostMs = millis();
}

void loop() {
  while (Serial.available() > 0) {
    char c = (char)Serial.read();
    if (c == '\n') {
      if (!lineOverflow) {
        line[lineLength] = '\0';
        if (lineLength > 0) handleLine(line);
      }
      lineLength = 0;
      lineOverflow = false;
    } else if (lineLength < MAX_LINE) {
      line[lineLength++] = c;
    } else {
      lineOverflow = true;  // drop the whole over-long line
    }
  }
  if (VALVE_FAILSAFE_MS > 0 && valveOpen && millis() - lastHostMs > VALVE_FAILSAFE_MS) {
    valveOpen = false;
    applyOutputs();
  }
}
