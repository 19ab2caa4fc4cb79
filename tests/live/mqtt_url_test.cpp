// The MQTT URLs of `stream --publish` and `merge --subscribe`, and the camera's topic name
// (live/mqtt_client.h, live/mqtt_publisher.h): what is read from them, and what is refused
// in one line naming the flag (and never showing the password).
#include <gtest/gtest.h>

#include <string>

#include "core/error.h"
#include "live/mqtt_client.h"
#include "live/mqtt_publisher.h"

namespace lp {
namespace {

TEST(MqttUrl, ReadsCredentialsHostPortAndTopic) {
  const MqttUrl u = parse_mqtt_url("mqtt://cam:p:w@broker.local:1884/studio/a", "--publish");
  EXPECT_FALSE(u.tls);
  EXPECT_EQ(u.user, "cam");
  EXPECT_EQ(u.password, "p:w");
  EXPECT_EQ(u.host, "broker.local");
  EXPECT_EQ(u.port, 1884);
  EXPECT_EQ(u.topic, "studio/a");
  const MqttUrl t = parse_mqtt_url("mqtts://[::1]/studio/+/lights", "--subscribe");
  EXPECT_TRUE(t.tls);
  EXPECT_EQ(t.host, "::1");
  EXPECT_EQ(t.port, 8883);
  EXPECT_EQ(t.topic, "studio/+/lights");
  EXPECT_EQ(parse_mqtt_url("mqtt://h/p", "--publish").port, 1883);
}

TEST(MqttUrl, RefusesMalformedOnesNamingTheFlagWithoutThePassword) {
  for (const char* bad : {"http://h:1/p", "mqtt://h:1", "mqtt://h:1/", "mqtt://:1/p", "mqtt://h:0/p", "mqtt://h:70000/p",
                          "mqtt://h:x/p", "mqtt://h:/p", "mqtt://h/a/#", "mqtt://h/a+/b", "mqtt://:secret@h/p",
                          "mqtt://[::1/p", "mqtt://u:secret@/p"}) {
    try {
      parse_mqtt_url(bad, "--publish");
      ADD_FAILURE() << bad << " was accepted";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind("--publish: ", 0), 0u) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
      EXPECT_EQ(what.find("secret"), std::string::npos) << what;
    }
  }
}

TEST(MqttCameraName, ComesFromTheSourceOrIsCheckedAsOneTopicLevel) {
  EXPECT_EQ(mqtt_camera_name("", "aravis:Fake_1", "--name"), "aravis-Fake_1");
  EXPECT_EQ(mqtt_camera_name("", "replay:/data/run3/", "--name"), "replay-run3");
  EXPECT_EQ(mqtt_camera_name("", "aravis", "--name"), "aravis");
  EXPECT_EQ(mqtt_camera_name("north", "aravis", "--name"), "north");
  for (const char* bad : {"a/b", "a+", "#", "merged"}) EXPECT_THROW(mqtt_camera_name(bad, "aravis", "--name"), InputError) << bad;
}

TEST(MqttPublisher, RefusesAWildcardPrefixAndABadQos) {
  MqttPublisherOptions o;
  o.camera = "cam";
  EXPECT_THROW(MqttPublisher("mqtt://127.0.0.1:1/studio/+", "--publish", o), InputError);
  o.qos = 2;
  EXPECT_THROW(MqttPublisher("mqtt://127.0.0.1:1/studio", "--publish", o), InputError);
}

}  // namespace
}  // namespace lp
