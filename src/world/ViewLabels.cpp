#include "world/ViewLabels.h"

#include <algorithm>
#include <map>
#include <string>

#include "common/Check.h"
#include "data/SubInstructions.h"
#include "data/Vocabulary.h"
#include "world/HouseGenerator.h"
#include "world/InstructionGenerator.h"

namespace vln::world {
namespace {

int64_t vocabularyIndex(const std::vector<std::string>& vocabulary,
                        const std::string& name) {
  const auto it = std::find(vocabulary.begin(), vocabulary.end(), name);
  return it == vocabulary.end() ? -1
                                : static_cast<int64_t>(it - vocabulary.begin());
}

}  // namespace

ViewLabels labelView(const sim::SceneSemantics& semantics,
                     std::span<const int32_t> objectIds, const Vec3f& position,
                     float minFraction) {
  const auto& categories = houseObjectCategories();
  const auto& colors = houseColorNames();
  const auto& rooms = houseRoomTypes();
  ViewLabels out;
  out.categories.assign(categories.size(), 0);
  out.colors.assign(colors.size(), 0);

  // the room under the camera
  const int room = semantics.roomAt(position);
  if (room >= 0) {
    const std::string& type = semantics.rooms[static_cast<size_t>(room)].type;
    const int64_t index = vocabularyIndex(rooms, type);
    VLN_CHECK_ARG(index >= 0, "labelView(): room ", room, " has type '", type,
                  "', which is not a generator room type");
    out.room = static_cast<int>(index);
  }

  // objects covering enough of the image
  std::map<int32_t, int64_t> pixels;
  for (int32_t id : objectIds)
    if (id >= 0) ++pixels[id];
  const double threshold =
      static_cast<double>(minFraction) * static_cast<double>(objectIds.size());
  for (const auto& [id, count] : pixels) {
    if (static_cast<double>(count) < threshold) continue;
    const sim::SemanticObject* object = semantics.object(id);
    VLN_CHECK_ARG(object != nullptr, "labelView(): object id ", id,
                  " in the semantic render is not in the scene's semantics");
    const int64_t category = vocabularyIndex(categories, object->category);
    VLN_CHECK_ARG(category >= 0, "labelView(): object ", id, " has category '",
                  object->category, "', which is not a generator category");
    const int64_t color = vocabularyIndex(colors, object->color);
    VLN_CHECK_ARG(color >= 0, "labelView(): object ", id, " has colour '",
                  object->color, "', which is not a generator colour");
    out.categories[static_cast<size_t>(category)] = 1;
    out.colors[static_cast<size_t>(color)] = 1;
  }
  return out;
}

int64_t viewLabelSize() {
  return static_cast<int64_t>(houseObjectCategories().size() +
                              houseColorNames().size() +
                              houseRoomTypes().size());
}

std::vector<float> viewLabelFeatures(sim::Renderer& renderer,
                                     const sim::SceneSemantics& semantics,
                                     const sim::AgentState& agent,
                                     const sim::PanoramaConfig& config,
                                     float minFraction) {
  const sim::CameraConfig& camera = config.rgb;
  const auto size = static_cast<size_t>(viewLabelSize());
  std::vector<float> out(static_cast<size_t>(config.num_views) * size, 0.0f);
  std::vector<int32_t> ids(static_cast<size_t>(camera.width) * camera.height);
  for (int view = 0; view < config.num_views; ++view) {
    // the pose of the panorama's colour camera (PanoramaRenderer)
    const sim::CameraPose pose{
        agent.position + Vec3f(0.0f, camera.position_y, 0.0f),
        sim::panoramaViewHeading(agent.heading, view, config.num_views),
        agent.pitch};
    renderer.renderSemantic(pose, {camera.width, camera.height, camera.hfov},
                            ids);
    const ViewLabels labels =
        labelView(semantics, ids, agent.position, minFraction);
    float* row = out.data() + static_cast<size_t>(view) * size;
    size_t at = 0;
    for (uint8_t c : labels.categories) row[at++] = c;
    for (uint8_t c : labels.colors) row[at++] = c;
    if (labels.room >= 0) row[at + static_cast<size_t>(labels.room)] = 1.0f;
  }
  return out;
}

namespace {

// whether `phrase` (tokens) occurs in tokens [first, last) of `tokens`
bool namesPhrase(const std::vector<std::string>& tokens, size_t first,
                 size_t last, const std::vector<std::string>& phrase) {
  last = std::min(last, tokens.size());
  if (phrase.empty() || first >= last) return false;
  const auto end = tokens.begin() + static_cast<std::ptrdiff_t>(last);
  return std::search(tokens.begin() + static_cast<std::ptrdiff_t>(first), end,
                     phrase.begin(), phrase.end()) != end;
}

// a label of viewLabelFeatures()' layout: the phrases (as tokens) that
// name it and its goalLabels() group
struct NamedLabel {
  std::vector<std::vector<std::string>> phrases;
  float group;
};

// every label in viewLabelFeatures()' order, tokenised once
const std::vector<NamedLabel>& namedLabels() {
  static const std::vector<NamedLabel> labels = [] {
    std::vector<NamedLabel> out;
    auto add = [&](const std::vector<std::string>& words, float group) {
      NamedLabel label{{}, group};
      for (const std::string& w : words)
        label.phrases.push_back(data::tokenize(w));
      out.push_back(std::move(label));
    };
    for (const std::string& c : houseObjectCategories())
      add(objectCategoryWords(c), kGoalCategory);
    for (const std::string& c : houseColorNames()) add({c}, kGoalColor);
    for (const std::string& r : houseRoomTypes())
      add(roomTypeWords(r), kGoalRoom);
    return out;
  }();
  return labels;
}

}  // namespace

std::vector<float> goalLabels(std::string_view instruction) {
  const std::vector<std::string> tokens = data::tokenize(instruction);
  const std::vector<data::SubInstructionTokens> clauses =
      data::ruleClauses(instruction);
  const std::vector<NamedLabel>& labels = namedLabels();
  std::vector<float> out(labels.size(), 0.0f);
  for (auto clause = clauses.rbegin(); clause != clauses.rend(); ++clause) {
    bool namesPlace = false;
    for (size_t i = 0; i < labels.size(); ++i)
      for (const auto& phrase : labels[i].phrases)
        if (namesPhrase(tokens, static_cast<size_t>(clause->first),
                        static_cast<size_t>(clause->last), phrase)) {
          out[i] = labels[i].group;
          namesPlace = namesPlace || labels[i].group != kGoalColor;
          break;
        }
    if (namesPlace) return out;
    std::fill(out.begin(), out.end(), 0.0f);
  }
  return out;
}

}  // namespace vln::world
