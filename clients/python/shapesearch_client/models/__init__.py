""" Contains all the data models used in inputs/outputs """

from .alignment_record import AlignmentRecord
from .attempt_resource import AttemptResource
from .body_search_by_upload import BodySearchByUpload
from .body_search_by_upload_units import BodySearchByUploadUnits
from .body_upload_model import BodyUploadModel
from .body_upload_model_assembly import BodyUploadModelAssembly
from .body_upload_model_metadata import BodyUploadModelMetadata
from .body_upload_model_units import BodyUploadModelUnits
from .body_upsert_model import BodyUpsertModel
from .body_upsert_model_assembly import BodyUpsertModelAssembly
from .body_upsert_model_metadata import BodyUpsertModelMetadata
from .body_upsert_model_units import BodyUpsertModelUnits
from .compare_points import ComparePoints
from .compare_response import CompareResponse
from .compare_response_units_type_0 import CompareResponseUnitsType0
from .cutoff_point import CutoffPoint
from .cutoff_record import CutoffRecord
from .cutoff_stats import CutoffStats
from .delivery_list import DeliveryList
from .delivery_resource import DeliveryResource
from .delivery_resource_event_type import DeliveryResourceEventType
from .delivery_resource_payload import DeliveryResourcePayload
from .delivery_resource_status import DeliveryResourceStatus
from .deviation_figures import DeviationFigures
from .duplicate_group_resource import DuplicateGroupResource
from .duplicate_member import DuplicateMember
from .duplicate_pair import DuplicatePair
from .duplicate_report_resource import DuplicateReportResource
from .duplicates_request import DuplicatesRequest
from .explanation import Explanation
from .explanation_points_source import ExplanationPointsSource
from .extents import Extents
from .file_info import FileInfo
from .health import Health
from .health_checks_type_0 import HealthChecksType0
from .job_list import JobList
from .job_resource import JobResource
from .job_resource_kind import JobResourceKind
from .job_resource_status import JobResourceStatus
from .job_summary import JobSummary
from .job_summary_status import JobSummaryStatus
from .list_jobs_status import ListJobsStatus
from .list_models_status import ListModelsStatus
from .metadata_filter import MetadataFilter
from .metadata_ranges import MetadataRanges
from .model_error import ModelError
from .model_list import ModelList
from .model_patch import ModelPatch
from .model_patch_metadata import ModelPatchMetadata
from .model_resource import ModelResource
from .model_resource_metadata import ModelResourceMetadata
from .model_resource_status import ModelResourceStatus
from .model_resource_timings_type_0 import ModelResourceTimingsType0
from .model_summary import ModelSummary
from .model_summary_metadata import ModelSummaryMetadata
from .part_points_response import PartPointsResponse
from .part_use import PartUse
from .parts_response import PartsResponse
from .point_set import PointSet
from .points_sources import PointsSources
from .points_sources_model import PointsSourcesModel
from .points_sources_other import PointsSourcesOther
from .problem import Problem
from .problem_checks import ProblemChecks
from .problem_errors_item import ProblemErrorsItem
from .recovered import Recovered
from .recovery import Recovery
from .revision_list import RevisionList
from .revision_resource import RevisionResource
from .revision_resource_status import RevisionResourceStatus
from .search_by_upload_mode import SearchByUploadMode
from .search_query import SearchQuery
from .search_response import SearchResponse
from .search_result import SearchResult
from .search_result_likeness_type_0 import SearchResultLikenessType0
from .similar_models_mode import SimilarModelsMode
from .similar_query import SimilarQuery
from .similar_response import SimilarResponse
from .similar_result import SimilarResult
from .similar_result_likeness_type_0 import SimilarResultLikenessType0
from .size import Size
from .size_units_type_0 import SizeUnitsType0
from .solver_calls_bin import SolverCallsBin
from .stats import Stats
from .stats_by_descriptor_version import StatsByDescriptorVersion
from .stats_by_status import StatsByStatus
from .stats_engine_libraries import StatsEngineLibraries
from .stats_jobs_by_status import StatsJobsByStatus
from .webhook_create import WebhookCreate
from .webhook_create_events_item import WebhookCreateEventsItem
from .webhook_created import WebhookCreated
from .webhook_created_events_item import WebhookCreatedEventsItem
from .webhook_list import WebhookList
from .webhook_resource import WebhookResource
from .webhook_resource_events_item import WebhookResourceEventsItem
from .where_used_entry import WhereUsedEntry
from .where_used_response import WhereUsedResponse

__all__ = (
    "AlignmentRecord",
    "AttemptResource",
    "BodySearchByUpload",
    "BodySearchByUploadUnits",
    "BodyUploadModel",
    "BodyUploadModelAssembly",
    "BodyUploadModelMetadata",
    "BodyUploadModelUnits",
    "BodyUpsertModel",
    "BodyUpsertModelAssembly",
    "BodyUpsertModelMetadata",
    "BodyUpsertModelUnits",
    "ComparePoints",
    "CompareResponse",
    "CompareResponseUnitsType0",
    "CutoffPoint",
    "CutoffRecord",
    "CutoffStats",
    "DeliveryList",
    "DeliveryResource",
    "DeliveryResourceEventType",
    "DeliveryResourcePayload",
    "DeliveryResourceStatus",
    "DeviationFigures",
    "DuplicateGroupResource",
    "DuplicateMember",
    "DuplicatePair",
    "DuplicateReportResource",
    "DuplicatesRequest",
    "Explanation",
    "ExplanationPointsSource",
    "Extents",
    "FileInfo",
    "Health",
    "HealthChecksType0",
    "JobList",
    "JobResource",
    "JobResourceKind",
    "JobResourceStatus",
    "JobSummary",
    "JobSummaryStatus",
    "ListJobsStatus",
    "ListModelsStatus",
    "MetadataFilter",
    "MetadataRanges",
    "ModelError",
    "ModelList",
    "ModelPatch",
    "ModelPatchMetadata",
    "ModelResource",
    "ModelResourceMetadata",
    "ModelResourceStatus",
    "ModelResourceTimingsType0",
    "ModelSummary",
    "ModelSummaryMetadata",
    "PartPointsResponse",
    "PartsResponse",
    "PartUse",
    "PointSet",
    "PointsSources",
    "PointsSourcesModel",
    "PointsSourcesOther",
    "Problem",
    "ProblemChecks",
    "ProblemErrorsItem",
    "Recovered",
    "Recovery",
    "RevisionList",
    "RevisionResource",
    "RevisionResourceStatus",
    "SearchByUploadMode",
    "SearchQuery",
    "SearchResponse",
    "SearchResult",
    "SearchResultLikenessType0",
    "SimilarModelsMode",
    "SimilarQuery",
    "SimilarResponse",
    "SimilarResult",
    "SimilarResultLikenessType0",
    "Size",
    "SizeUnitsType0",
    "SolverCallsBin",
    "Stats",
    "StatsByDescriptorVersion",
    "StatsByStatus",
    "StatsEngineLibraries",
    "StatsJobsByStatus",
    "WebhookCreate",
    "WebhookCreated",
    "WebhookCreatedEventsItem",
    "WebhookCreateEventsItem",
    "WebhookList",
    "WebhookResource",
    "WebhookResourceEventsItem",
    "WhereUsedEntry",
    "WhereUsedResponse",
)
