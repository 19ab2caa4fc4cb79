// libmosquitto, loaded on first use. It links OpenSSL (libssl, libcrypto, whose start-up
// builds its tables), which every lightprobe command loaded at start though only the MQTT
// publisher and merger (mqtt_client.cpp) connect to a broker. The library is not linked;
// these definitions of the mosquitto functions the project calls forward to the real ones,
// which the first call loads from libmosquitto.so.1 with dlopen (as calib/mrcal_loader.cpp
// does for mrcal).
//
// The definitions are checked against mosquitto.h by the compiler (a C function cannot be
// overloaded: a wrong parameter list does not compile). A function the project starts to
// call must be added here: the link fails until it is.
#include "core/lazy_function.h"

#include <mosquitto.h>

namespace {

constexpr const char* kMosquittoLibrary = "libmosquitto.so.1";

#define LP_MOSQUITTO(name) LP_LAZY_FUNCTION(kMosquittoLibrary, "libmosquitto 2.x", name)

}  // namespace

extern "C" {

int mosquitto_lib_init(void) {
  LP_MOSQUITTO(mosquitto_lib_init);
  return real();
}

struct mosquitto* mosquitto_new(const char* id, bool clean_session, void* obj) {
  LP_MOSQUITTO(mosquitto_new);
  return real(id, clean_session, obj);
}

void mosquitto_destroy(struct mosquitto* mosq) {
  LP_MOSQUITTO(mosquitto_destroy);
  real(mosq);
}

void mosquitto_connect_callback_set(struct mosquitto* mosq, void (*on_connect)(struct mosquitto*, void*, int)) {
  LP_MOSQUITTO(mosquitto_connect_callback_set);
  real(mosq, on_connect);
}

void mosquitto_disconnect_callback_set(struct mosquitto* mosq, void (*on_disconnect)(struct mosquitto*, void*, int)) {
  LP_MOSQUITTO(mosquitto_disconnect_callback_set);
  real(mosq, on_disconnect);
}

void mosquitto_message_callback_set(struct mosquitto* mosq, void (*on_message)(struct mosquitto*, void*, const struct mosquitto_message*)) {
  LP_MOSQUITTO(mosquitto_message_callback_set);
  real(mosq, on_message);
}

void mosquitto_publish_callback_set(struct mosquitto* mosq, void (*on_publish)(struct mosquitto*, void*, int)) {
  LP_MOSQUITTO(mosquitto_publish_callback_set);
  real(mosq, on_publish);
}

void mosquitto_log_callback_set(struct mosquitto* mosq, void (*on_log)(struct mosquitto*, void*, int, const char*)) {
  LP_MOSQUITTO(mosquitto_log_callback_set);
  real(mosq, on_log);
}

int mosquitto_username_pw_set(struct mosquitto* mosq, const char* username, const char* password) {
  LP_MOSQUITTO(mosquitto_username_pw_set);
  return real(mosq, username, password);
}

int mosquitto_tls_set(struct mosquitto* mosq, const char* cafile, const char* capath, const char* certfile, const char* keyfile, int (*pw_callback)(char* buf, int size, int rwflag, void* userdata)) {
  LP_MOSQUITTO(mosquitto_tls_set);
  return real(mosq, cafile, capath, certfile, keyfile, pw_callback);
}

int mosquitto_will_set(struct mosquitto* mosq, const char* topic, int payloadlen, const void* payload, int qos, bool retain) {
  LP_MOSQUITTO(mosquitto_will_set);
  return real(mosq, topic, payloadlen, payload, qos, retain);
}

int mosquitto_threaded_set(struct mosquitto* mosq, bool threaded) {
  LP_MOSQUITTO(mosquitto_threaded_set);
  return real(mosq, threaded);
}

int mosquitto_loop(struct mosquitto* mosq, int timeout, int max_packets) {
  LP_MOSQUITTO(mosquitto_loop);
  return real(mosq, timeout, max_packets);
}

int mosquitto_socket(struct mosquitto* mosq) {
  LP_MOSQUITTO(mosquitto_socket);
  return real(mosq);
}

int mosquitto_connect_async(struct mosquitto* mosq, const char* host, int port, int keepalive) {
  LP_MOSQUITTO(mosquitto_connect_async);
  return real(mosq, host, port, keepalive);
}

int mosquitto_reconnect_async(struct mosquitto* mosq) {
  LP_MOSQUITTO(mosquitto_reconnect_async);
  return real(mosq);
}

int mosquitto_disconnect(struct mosquitto* mosq) {
  LP_MOSQUITTO(mosquitto_disconnect);
  return real(mosq);
}

int mosquitto_publish(struct mosquitto* mosq, int* mid, const char* topic, int payloadlen, const void* payload, int qos, bool retain) {
  LP_MOSQUITTO(mosquitto_publish);
  return real(mosq, mid, topic, payloadlen, payload, qos, retain);
}

int mosquitto_subscribe(struct mosquitto* mosq, int* mid, const char* sub, int qos) {
  LP_MOSQUITTO(mosquitto_subscribe);
  return real(mosq, mid, sub, qos);
}

const char* mosquitto_strerror(int mosq_errno) {
  LP_MOSQUITTO(mosquitto_strerror);
  return real(mosq_errno);
}

const char* mosquitto_connack_string(int connack_code) {
  LP_MOSQUITTO(mosquitto_connack_string);
  return real(connack_code);
}

}  // extern "C"
