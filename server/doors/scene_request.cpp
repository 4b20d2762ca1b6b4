#include "doors/scene_request.h"

#include <cctype>
#include <charconv>
#include <memory>
#include <string>

#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/presets.h"
#include "dembuf/study/scene/scene_fields.h"
#include "dembuf/study/sweep/sweep_plan.h"

namespace dembuf::server {

namespace {

using google::protobuf::FieldDescriptor;
using google::protobuf::Message;

// The shortest text that reads back as the same double (NaN and infinities included, so that
// the field's own range check rejects them with its usual message).
std::string ExactText(double v) {
  char buf[64];
  const auto result = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, result.ptr);
}

void ApplyMessage(const Message& message, const std::string& prefix, Scene& scene) {
  const auto* descriptor = message.GetDescriptor();
  const auto* reflection = message.GetReflection();
  // A field this daemon's API does not have (a client of another version, a withdrawn field)
  // is refused, not dropped: the job would run without what was asked.
  if (const auto& unknown = reflection->GetUnknownFields(message); !unknown.empty())
    throw SceneError(prefix.empty() ? "scene" : prefix,
                     "field number " + std::to_string(unknown.field(0).number()) +
                         " is not one of this daemon's API (a client of another version?)");
  for (int i = 0; i < descriptor->field_count(); ++i) {
    const FieldDescriptor* field = descriptor->field(i);
    const std::string name = prefix.empty() ? field->name() : prefix + "." + field->name();
    if (field->is_repeated()) {
      const int count = reflection->FieldSize(message, field);
      if (count == 0) continue;
      std::string list;
      for (int k = 0; k < count; ++k) {
        if (k > 0) list.push_back(',');
        list.append(ExactText(reflection->GetRepeatedDouble(message, field, k)));
      }
      SetSceneField(scene, name, list);
      continue;
    }
    if (!reflection->HasField(message, field)) continue;
    switch (field->cpp_type()) {
      case FieldDescriptor::CPPTYPE_MESSAGE:
        ApplyMessage(reflection->GetMessage(message, field), name, scene);
        break;
      case FieldDescriptor::CPPTYPE_DOUBLE:
        SetSceneField(scene, name, ExactText(reflection->GetDouble(message, field)));
        break;
      case FieldDescriptor::CPPTYPE_INT64:
        SetSceneField(scene, name, std::to_string(reflection->GetInt64(message, field)));
        break;
      case FieldDescriptor::CPPTYPE_BOOL:
        SetSceneField(scene, name, reflection->GetBool(message, field) ? "true" : "false");
        break;
      case FieldDescriptor::CPPTYPE_STRING:
        SetSceneField(scene, name, reflection->GetString(message, field));
        break;
      default:
        throw SceneError(name, "unsupported field type in the API");
    }
  }
}

}  // namespace

void ApplyProtoScene(const v1::Scene& fields, Scene& scene) {
  ApplyMessage(fields, "", scene);
}

Scene ResolveSceneSpec(const v1::SceneSpec& spec, const std::optional<BedFile>& bed_file) {
  if (spec.set_size() > kMaxAssignments)
    throw SceneError("set", std::to_string(spec.set_size()) + " assignments; at most " +
                                std::to_string(kMaxAssignments));
  Scene scene;
  if (!spec.preset().empty()) scene = PresetScene(spec.preset());
  if (!spec.scene_toml().empty()) scene = LoadSceneText(spec.scene_toml(), "scene_toml", scene);
  if (!spec.accuracy().empty()) ApplyAccuracy(scene, spec.accuracy());
  ApplyProtoScene(spec.scene(), scene);
  for (const std::string& assignment : spec.set()) ApplyOverride(scene, assignment);
  if (!spec.bed_file().empty()) {
    if (!bed_file) throw SceneError("bed_file", "no bed file " + spec.bed_file());
    scene.bed.import = bed_file->name;
    scene.bed.import_bytes = bed_file->data;
    scene.bed.import_sha256 = bed_file->sha256;  // checked against the bytes as it was read
  }
  return scene;  // validated by AdmitScene, once it is the scene that will run
}

void CheckSweepAxes(const v1::SubmitSweepRequest& request) {
  if (request.axes_size() > kMaxAxes)
    throw SceneError(
        "axes", std::to_string(request.axes_size()) + " axes; at most " + std::to_string(kMaxAxes));
  for (const auto& axis : request.axes())
    if (axis.values_size() > kMaxAxisValues)
      throw SceneError(axis.field(), std::to_string(axis.values_size()) +
                                         " values in the sweep axis; at most " +
                                         std::to_string(kMaxAxisValues));
  // A table's size before any of its values is read.
  const v1::SweepTable& table = request.table();
  if (request.has_table() && (table.fields_size() == 0 || table.rows_size() == 0))
    throw SceneError("table", "a table needs at least one column and one row");
  if (table.fields_size() > kMaxAxes)
    throw SceneError("table", std::to_string(table.fields_size()) + " columns; at most " +
                                  std::to_string(kMaxAxes));
  if (static_cast<std::size_t>(table.rows_size()) > kMaxTableRows)
    throw SceneError("table", std::to_string(table.rows_size()) + " rows; at most " +
                                  std::to_string(kMaxTableRows));
  for (int r = 0; r < table.rows_size(); ++r) {
    for (const std::string& value : table.rows(r).values()) CheckSweepValueLength("table", value);
    if (table.rows(r).values_size() != table.fields_size())
      throw SceneError("table", "row " + std::to_string(r + 1) + " has " +
                                    std::to_string(table.rows(r).values_size()) + " values for " +
                                    std::to_string(table.fields_size()) + " columns");
  }
}

}  // namespace dembuf::server
